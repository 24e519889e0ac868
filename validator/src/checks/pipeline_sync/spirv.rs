//! A reader for the few SPIR-V facts the micromap rules need: declared
//! capabilities, entry points, the `OpacityMicromapIdKHR` execution mode and
//! the Rayflags operands of trace and ray-query instructions, with the
//! constants (and specialization constants) they resolve to.
//!
//! Written by hand rather than with rspirv: rspirv's grammar (SDK 1.3.268)
//! predates `SPV_KHR_opacity_micromap`, so its parser rejects the very
//! modules these rules are about (execution mode 6031 is unknown to it).

use std::collections::{BTreeMap, BTreeSet};

use crate::model::pipeline::SpecializationValue;

const MAGIC: u32 = 0x0723_0203;
const HEADER_WORDS: usize = 5;

const OP_CAPABILITY: u32 = 17;
const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE_ID: u32 = 331;
const OP_DECORATE: u32 = 71;
const OP_CONSTANT_TRUE: u32 = 41;
const OP_CONSTANT_FALSE: u32 = 42;
const OP_CONSTANT: u32 = 43;
const OP_SPEC_CONSTANT_TRUE: u32 = 48;
const OP_SPEC_CONSTANT_FALSE: u32 = 49;
const OP_SPEC_CONSTANT: u32 = 50;

const DECORATION_SPEC_ID: u32 = 1;
/// `RayTracingOpacityMicromapKHR` (alias of `RayTracingOpacityMicromapEXT`).
pub const CAPABILITY_RAY_TRACING_OPACITY_MICROMAP: u32 = 5381;
/// `OpacityMicromapIdKHR`.
pub const EXECUTION_MODE_OPACITY_MICROMAP_ID: u32 = 6031;
/// `ForceOpacityMicromap2StateKHR` in a Rayflags operand.
pub const RAY_FLAGS_FORCE_OPACITY_MICROMAP_2_STATE: u64 = 0x400;

/// Instructions with a Rayflags operand: (opcode, name, operand index after
/// the opcode word).
const RAY_FLAG_INSTRUCTIONS: [(u32, &str, usize); 9] = [
    (4445, "OpTraceRayKHR", 1),
    (4473, "OpRayQueryInitializeKHR", 2),
    (5337, "OpTraceNV", 1),
    (5338, "OpTraceMotionNV", 1),
    (5339, "OpTraceRayMotionNV", 1),
    (5256, "OpHitObjectTraceRayMotionNV", 2),
    (5260, "OpHitObjectTraceRayNV", 2),
    (5316, "OpHitObjectTraceRayEXT", 2),
    (5317, "OpHitObjectTraceRayMotionEXT", 2),
];

/// Where a constant's value comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// `OpConstant*`: fixed when the module is created.
    Constant,
    /// `OpSpecConstant*`: may be specialized when a pipeline or shader is created.
    Specialization,
}

#[derive(Clone, Copy, Debug)]
struct Constant {
    default: u64,
    origin: Origin,
    boolean: bool,
}

/// A Rayflags operand of one instruction.
#[derive(Clone, Copy, Debug)]
struct RayFlagsOperand {
    instruction: &'static str,
    /// The instruction's index in the module (0 is the first after the header).
    index: usize,
    operand: u32,
}

/// A Rayflags operand whose value is a constant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConstantRayFlags {
    pub instruction: &'static str,
    pub index: usize,
    pub flags: u64,
    pub origin: Origin,
}

/// The facts of one module.
#[derive(Clone, Debug, Default)]
pub struct SpirvModule {
    capabilities: BTreeSet<u32>,
    /// (result id, name) of each `OpEntryPoint`.
    entry_points: Vec<(u32, String)>,
    /// (entry point id, operand id) of each `OpExecutionModeId ... OpacityMicromapIdKHR`.
    opacity_micromap_id_modes: Vec<(u32, u32)>,
    constants: BTreeMap<u32, Constant>,
    spec_ids: BTreeMap<u32, u32>,
    ray_flags: Vec<RayFlagsOperand>,
}

impl SpirvModule {
    /// Reads `words`; None when they are not a well-formed module (another
    /// rule's business).
    pub fn parse(words: &[u32]) -> Option<Self> {
        let swapped = match words.first() {
            Some(&MAGIC) => false,
            Some(&w) if w.swap_bytes() == MAGIC => true,
            _ => return None,
        };
        let word = |i: usize| -> Option<u32> {
            let w = *words.get(i)?;
            Some(if swapped { w.swap_bytes() } else { w })
        };
        let mut module = Self::default();
        let mut at = HEADER_WORDS;
        let mut index = 0usize;
        while at < words.len() {
            let first = word(at)?;
            let count = usize::try_from(first >> 16).ok()?;
            if count == 0 || at.checked_add(count)? > words.len() {
                return None;
            }
            let operands: Vec<u32> = (at + 1..at + count).filter_map(word).collect();
            module.instruction(first & 0xffff, &operands, index);
            at += count;
            index += 1;
        }
        Some(module)
    }

    fn instruction(&mut self, opcode: u32, operands: &[u32], index: usize) {
        let op = |i: usize| operands.get(i).copied();
        match opcode {
            OP_CAPABILITY => self.capabilities.extend(op(0)),
            OP_ENTRY_POINT => {
                if let Some(id) = op(1) {
                    let name = literal_string(operands.get(2..).unwrap_or_default());
                    self.entry_points.push((id, name));
                }
            }
            OP_EXECUTION_MODE_ID => {
                if let (Some(entry), Some(EXECUTION_MODE_OPACITY_MICROMAP_ID), Some(operand)) =
                    (op(0), op(1), op(2))
                {
                    self.opacity_micromap_id_modes.push((entry, operand));
                }
            }
            OP_DECORATE => {
                if let (Some(target), Some(DECORATION_SPEC_ID), Some(spec_id)) =
                    (op(0), op(1), op(2))
                {
                    self.spec_ids.insert(target, spec_id);
                }
            }
            OP_CONSTANT_TRUE
            | OP_CONSTANT_FALSE
            | OP_SPEC_CONSTANT_TRUE
            | OP_SPEC_CONSTANT_FALSE => {
                if let Some(id) = op(1) {
                    let spec = matches!(opcode, OP_SPEC_CONSTANT_TRUE | OP_SPEC_CONSTANT_FALSE);
                    let truth = matches!(opcode, OP_CONSTANT_TRUE | OP_SPEC_CONSTANT_TRUE);
                    self.constant(id, u64::from(truth), spec, true);
                }
            }
            OP_CONSTANT | OP_SPEC_CONSTANT => {
                if let (Some(id), Some(low)) = (op(1), op(2)) {
                    let high = op(3).unwrap_or(0);
                    let value = u64::from(low) | u64::from(high) << 32;
                    self.constant(id, value, opcode == OP_SPEC_CONSTANT, false);
                }
            }
            _ => {
                if let Some((_, name, position)) = RAY_FLAG_INSTRUCTIONS
                    .iter()
                    .find(|(code, _, _)| *code == opcode)
                {
                    if let Some(operand) = op(*position) {
                        self.ray_flags.push(RayFlagsOperand {
                            instruction: name,
                            index,
                            operand,
                        });
                    }
                }
            }
        }
    }

    fn constant(&mut self, id: u32, default: u64, spec: bool, boolean: bool) {
        let origin = if spec {
            Origin::Specialization
        } else {
            Origin::Constant
        };
        self.constants.insert(
            id,
            Constant {
                default,
                origin,
                boolean,
            },
        );
    }

    /// The value of constant `id` under `specialization`.
    fn value(&self, id: u32, specialization: &[SpecializationValue]) -> Option<(u64, Origin)> {
        let constant = self.constants.get(&id)?;
        let specialized = (constant.origin == Origin::Specialization)
            .then(|| self.spec_ids.get(&id))
            .flatten()
            .and_then(|spec_id| specialization.iter().find(|s| s.constant_id == *spec_id))
            .map(|s| s.value);
        let value = specialized.unwrap_or(constant.default);
        let value = if constant.boolean {
            u64::from(value & 0xffff_ffff != 0)
        } else {
            value
        };
        Some((value, constant.origin))
    }

    pub fn declares_capability(&self, capability: u32) -> bool {
        self.capabilities.contains(&capability)
    }

    /// The Rayflags operands whose value is a constant, specialized by
    /// `specialization`; operands computed at run time are left out.
    pub fn constant_ray_flags(
        &self,
        specialization: &[SpecializationValue],
    ) -> Vec<ConstantRayFlags> {
        self.ray_flags
            .iter()
            .filter_map(|use_| {
                let (flags, origin) = self.value(use_.operand, specialization)?;
                Some(ConstantRayFlags {
                    instruction: use_.instruction,
                    index: use_.index,
                    flags,
                    origin,
                })
            })
            .collect()
    }

    /// Whether the entry point named `name` declares `OpacityMicromapIdKHR`
    /// with an operand that is true under `specialization`.
    pub fn opacity_micromap_id(&self, name: &str, specialization: &[SpecializationValue]) -> bool {
        self.entry_points
            .iter()
            .filter(|(_, entry_name)| entry_name == name)
            .any(|(entry, _)| {
                self.opacity_micromap_id_modes
                    .iter()
                    .filter(|(mode_entry, _)| mode_entry == entry)
                    .any(|(_, operand)| {
                        self.value(*operand, specialization)
                            .is_some_and(|(value, _)| value != 0)
                    })
            })
    }
}

/// A nul-terminated UTF-8 literal packed little-endian into words.
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .take_while(|b| *b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Builders of small modules for tests (here and in the case files).
pub mod build {
    use super::*;

    /// One instruction: the opcode word and its operands.
    pub fn instruction(opcode: u32, operands: &[u32]) -> Vec<u32> {
        let count = u32::try_from(operands.len() + 1).unwrap_or(u32::MAX);
        let mut words = vec![count << 16 | opcode];
        words.extend_from_slice(operands);
        words
    }

    /// A literal string as words.
    pub fn string(text: &str) -> Vec<u32> {
        let mut bytes = text.as_bytes().to_vec();
        bytes.push(0);
        while !bytes.len().is_multiple_of(4) {
            bytes.push(0);
        }
        bytes
            .chunks(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    /// What a test module contains.
    #[derive(Clone, Debug, Default)]
    pub struct TestModule {
        /// Declare `RayTracingOpacityMicromapKHR`.
        pub capability: bool,
        /// Rayflags of an `OpTraceRayKHR`, as a plain constant.
        pub trace_ray_flags: Option<u32>,
        /// Rayflags of an `OpRayQueryInitializeKHR`, as a specialization
        /// constant with SpecId 7 and this default.
        pub ray_query_spec_flags: Option<u32>,
        /// `OpacityMicromapIdKHR` on `main` with a boolean constant: (value,
        /// whether it is a specialization constant with SpecId 3).
        pub opacity_micromap_id: Option<(bool, bool)>,
    }

    impl TestModule {
        /// The module's words (not a valid shader beyond what the reader needs).
        pub fn words(&self) -> Vec<u32> {
            let mut words = vec![MAGIC, 0x0001_0600, 0, 100, 0];
            let main = 1;
            words.extend(instruction(OP_CAPABILITY, &[4479])); // RayQueryKHR
            if self.capability {
                words.extend(instruction(
                    OP_CAPABILITY,
                    &[CAPABILITY_RAY_TRACING_OPACITY_MICROMAP],
                ));
            }
            let mut entry = vec![5313, main]; // RayGenerationKHR
            entry.extend(string("main"));
            words.extend(instruction(OP_ENTRY_POINT, &entry));
            if let Some((_, true)) = self.opacity_micromap_id {
                words.extend(instruction(OP_DECORATE, &[20, DECORATION_SPEC_ID, 3]));
            }
            if self.ray_query_spec_flags.is_some() {
                words.extend(instruction(OP_DECORATE, &[31, DECORATION_SPEC_ID, 7]));
            }
            if let Some((value, spec)) = self.opacity_micromap_id {
                let opcode = match (value, spec) {
                    (true, true) => OP_SPEC_CONSTANT_TRUE,
                    (false, true) => OP_SPEC_CONSTANT_FALSE,
                    (true, false) => OP_CONSTANT_TRUE,
                    (false, false) => OP_CONSTANT_FALSE,
                };
                words.extend(instruction(opcode, &[2, 20]));
                words.extend(instruction(
                    OP_EXECUTION_MODE_ID,
                    &[main, EXECUTION_MODE_OPACITY_MICROMAP_ID, 20],
                ));
            }
            if let Some(flags) = self.trace_ray_flags {
                words.extend(instruction(OP_CONSTANT, &[3, 30, flags]));
                words.extend(instruction(
                    4445,
                    &[40, 30, 30, 30, 30, 30, 41, 42, 43, 44, 45],
                ));
            }
            if let Some(flags) = self.ray_query_spec_flags {
                words.extend(instruction(OP_SPEC_CONSTANT, &[3, 31, flags]));
                words.extend(instruction(4473, &[50, 40, 31, 30, 41, 42, 43, 44]));
            }
            words
        }
    }
}

#[cfg(test)]
mod tests {
    use super::build::*;
    use super::*;

    #[test]
    fn rejects_what_is_not_spirv() {
        assert!(SpirvModule::parse(&[]).is_none());
        assert!(SpirvModule::parse(&[1, 2, 3, 4, 5]).is_none());
        // A zero word count and an instruction running past the end.
        assert!(SpirvModule::parse(&[MAGIC, 0, 0, 0, 0, 0]).is_none());
        assert!(SpirvModule::parse(&[MAGIC, 0, 0, 0, 0, 3 << 16 | OP_CAPABILITY]).is_none());
    }

    #[test]
    fn reads_byte_swapped_modules() {
        let words: Vec<u32> = TestModule {
            capability: true,
            ..Default::default()
        }
        .words()
        .into_iter()
        .map(u32::swap_bytes)
        .collect();
        let module = SpirvModule::parse(&words).unwrap();
        assert!(module.declares_capability(CAPABILITY_RAY_TRACING_OPACITY_MICROMAP));
    }

    #[test]
    fn resolves_ray_flags_and_their_specialization() {
        let module = SpirvModule::parse(
            &TestModule {
                trace_ray_flags: Some(0x401),
                ray_query_spec_flags: Some(0x1),
                ..Default::default()
            }
            .words(),
        )
        .unwrap();
        let flags = module.constant_ray_flags(&[]);
        assert_eq!(flags.len(), 2);
        assert_eq!((flags[0].flags, flags[0].origin), (0x401, Origin::Constant));
        assert_eq!(
            (flags[1].instruction, flags[1].flags),
            ("OpRayQueryInitializeKHR", 0x1)
        );
        let specialized = module.constant_ray_flags(&[SpecializationValue {
            constant_id: 7,
            value: 0x400,
        }]);
        assert_eq!(
            (specialized[1].flags, specialized[1].origin),
            (0x400, Origin::Specialization)
        );
    }

    #[test]
    fn opacity_micromap_id_follows_its_specialization() {
        let module = SpirvModule::parse(
            &TestModule {
                opacity_micromap_id: Some((true, true)),
                ..Default::default()
            }
            .words(),
        )
        .unwrap();
        assert!(module.opacity_micromap_id("main", &[]));
        assert!(!module.opacity_micromap_id("other", &[]));
        let off = [SpecializationValue {
            constant_id: 3,
            value: 0,
        }];
        assert!(!module.opacity_micromap_id("main", &off));
    }
}
