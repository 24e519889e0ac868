//! Where a finding points in a call's arguments (`pInfos[2].pGeometries[0]
//! .geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer`),
//! as one type for every check and reader.
//!
//! A location is a value that is written out only when a finding names
//! it: most calls have no finding, and building every location string was
//! most of a valid call's cost. Locations nest by value, one step at a
//! time, from any root that is `Display + Copy` (a parameter name, or an
//! enum of the spellings a root may take):
//!
//! ```
//! use ommcheck::report::location::Locate;
//!
//! let info = "pInfos".index(2);
//! let index_buffer = info.member("pGeometries").index(0).text(".geometry.triangles").member("indexBuffer");
//! assert_eq!(index_buffer.to_string(), "pInfos[2].pGeometries[0].geometry.triangles.indexBuffer");
//! ```

use std::fmt::{self, Display};

/// A place in a call's arguments: `parent` followed by one step.
#[derive(Clone, Copy, Debug)]
pub struct Location<'n, P> {
    parent: P,
    step: Step<'n>,
}

/// One step from a location to the next.
#[derive(Clone, Copy, Debug)]
enum Step<'n> {
    /// `.name`: a member.
    Member(&'n str),
    /// `[i]`: an element.
    Index(u64),
    /// Text as it is: members with their own separators
    /// (`.pNext<VkAccelerationStructureGeometryMicromapDataKHR>`).
    Text(&'n str),
}

impl<P: Display> Display for Location<'_, P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.parent.fmt(f)?;
        match self.step {
            Step::Member(name) => write!(f, ".{name}"),
            Step::Index(i) => write!(f, "[{i}]"),
            Step::Text(text) => f.write_str(text),
        }
    }
}

/// The steps from any location (or root) to the next.
pub trait Locate: Display + Copy + Sized {
    /// The member `name`: `{self}.{name}`.
    fn member(self, name: &str) -> Location<'_, Self> {
        Location {
            parent: self,
            step: Step::Member(name),
        }
    }

    /// Element `i`: `{self}[{i}]`.
    fn index(self, i: impl TryInto<u64>) -> Location<'static, Self> {
        Location {
            parent: self,
            step: Step::Index(i.try_into().unwrap_or(u64::MAX)),
        }
    }

    /// `text` as it is: `{self}{text}`.
    fn text(self, text: &str) -> Location<'_, Self> {
        Location {
            parent: self,
            step: Step::Text(text),
        }
    }
}

impl<T: Display + Copy> Locate for T {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_write_out_in_order() {
        let entry = "pInfos".index(0).member("triangleArray").index(7_u64);
        assert_eq!(entry.to_string(), "pInfos[0].triangleArray[7]");
        assert_eq!(
            entry.member("dataOffset").to_string(),
            "pInfos[0].triangleArray[7].dataOffset"
        );
        let chained = "pInfos"
            .index(1_usize)
            .text(".pNext<VkAccelerationStructureGeometryMicromapDataKHR>")
            .member("pUsageCounts")
            .index(2);
        assert_eq!(
            chained.to_string(),
            "pInfos[1].pNext<VkAccelerationStructureGeometryMicromapDataKHR>.pUsageCounts[2]"
        );
    }
}
