//! The model → scene writer: turns the model of a call's structures back
//! into the scene form, so that a run seen by the layer or the static API
//! can be written out as a scene that reads back to the same calls. The
//! writers themselves are generated ([`generated`]); what they need to know
//! of the run, the names of its objects and memory, comes through
//! [`Names`].

use crate::model::micromap::{MicromapUsage, UsageCounts};
use crate::model::names::Value;
use crate::model::Handle;
use crate::scene::args::{AddressArg, HandleArg};
use crate::scene::format::{ChainStruct, Contents, OtherStruct, Piece, UsageDesc};
use crate::scene::ObjectKind;

mod generated;

/// How a writer names what the model holds as numbers.
pub trait Names {
    /// The scene's form of `handle`, an object of `kind`: its name where
    /// the run named it, else the number (0 is `null`).
    fn handle(&self, kind: ObjectKind, handle: Handle) -> HandleArg;
    /// The scene's form of `address`: in a named buffer or host block, or
    /// the number (0 is `null`).
    fn address(&self, address: u64) -> AddressArg;
}

/// Names nothing: handles and addresses are written as numbers.
pub struct Numbers;

impl Names for Numbers {
    fn handle(&self, _: ObjectKind, handle: Handle) -> HandleArg {
        match handle {
            0 => HandleArg::Null,
            raw => HandleArg::Raw(raw),
        }
    }

    fn address(&self, address: u64) -> AddressArg {
        match address {
            0 => AddressArg::Null,
            raw => AddressArg::Raw(raw),
        }
    }
}

/// A pNext entry of which the model kept only the sType. An sType of a
/// structure the scene form reads comes back as that structure with its
/// members at their defaults: the model did not keep them.
pub(crate) fn chain_entry(s_type: i32) -> ChainStruct {
    ChainStruct::Other(OtherStruct {
        s_type: Value::new(i64::from(s_type)),
        structure: None,
    })
}

/// A count of an array or an array of pointers, where the resolver would
/// not take it from the given array's length (None: it would).
pub(crate) fn elements_count<T>(
    count: u32,
    array: &Option<Vec<T>>,
    pointers: &Option<Vec<Option<T>>>,
) -> Option<u32> {
    let implied = match (array, pointers) {
        (Some(array), _) => array.len(),
        (None, Some(pointers)) => pointers.len(),
        (None, None) => 0,
    };
    (u32::try_from(implied) != Ok(count)).then_some(count)
}

/// Bytes as scene contents: one piece of bytes at 0.
pub(crate) fn contents(bytes: &[u8]) -> Contents {
    Contents::One(Piece {
        u8: Some(bytes.to_vec()),
        ..Piece::default()
    })
}

/// `usageCountsCount` where the resolver would not take it from the
/// arrays' length (None: it would).
pub(crate) fn usage_counts_count(counts: &UsageCounts) -> Option<u32> {
    elements_count(counts.count, &counts.array, &counts.pointers)
}

/// The scene form of one `VkMicromapUsageEXT`.
pub(crate) fn usage_desc(usage: &MicromapUsage) -> UsageDesc {
    UsageDesc {
        count: usage.count,
        subdivision_level: usage.subdivision_level,
        format: Value::new(i64::from(usage.format)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::micromap_objects::CopyMicromapToMemoryInfo;
    use crate::model::names::{BufferUsageFlags, CopyMicromapMode, Written};
    use crate::scene::format::CopyMicromapToMemoryInfoDesc;

    /// Names a run's one micromap and one buffer, as a capture would.
    struct OneOfEach;

    impl Names for OneOfEach {
        fn handle(&self, kind: ObjectKind, handle: Handle) -> HandleArg {
            match (kind, handle) {
                (ObjectKind::Micromap, 0x33_0001) => HandleArg::Name("omm".into()),
                _ => Numbers.handle(kind, handle),
            }
        }

        fn address(&self, address: u64) -> AddressArg {
            match address.checked_sub(0x1_0000_0000) {
                Some(offset) if offset < 4096 => AddressArg::Buffer {
                    name: "serialized".into(),
                    offset,
                },
                _ => Numbers.address(address),
            }
        }
    }

    #[test]
    fn a_written_structure_names_objects_and_leaves_defaults_out() {
        let model = CopyMicromapToMemoryInfo {
            src: 0x33_0001,
            dst: 0x1_0000_0010,
            ..Default::default()
        };
        let json = serde_json::to_value(CopyMicromapToMemoryInfoDesc::written(&model, &OneOfEach))
            .unwrap();
        assert_eq!(
            json,
            serde_json::json!({"src": "omm", "dst": {"buffer": "serialized", "offset": 16}})
        );
        let clone = CopyMicromapToMemoryInfo { mode: 0, ..model };
        let json = serde_json::to_value(CopyMicromapToMemoryInfoDesc::written(&clone, &OneOfEach))
            .unwrap();
        assert_eq!(json["mode"], "VK_COPY_MICROMAP_MODE_CLONE_EXT");
    }

    #[test]
    fn values_are_written_by_name_where_every_bit_has_one() {
        let two_bits = Value::<BufferUsageFlags>::new(0x20 | 0x20000);
        assert_eq!(
            two_bits.written(),
            Written::Name(
                "VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"
                    .into()
            )
        );
        // Bit 62 has no name: the number.
        let unnamed = Value::<BufferUsageFlags>::new(1 << 62 | 0x20);
        assert_eq!(unnamed.written(), Written::Number(1 << 62 | 0x20));
        assert_eq!(
            Value::<CopyMicromapMode>::new(77).written(),
            Written::Number(77)
        );
    }
}
