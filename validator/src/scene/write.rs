//! The model → scene writer: turns the model of a call's structures back
//! into the scene form, so that a run seen by the layer or the static API
//! can be written out as a scene that reads back to the same calls. The
//! writers themselves are generated ([`generated`]); what they need to know
//! of the run, the names of its objects and memory, comes through
//! [`Names`].

use crate::model::accel::AccelerationStructureCreateInfo2;
use crate::model::command::CommandBuffer;
use crate::model::micromap::{MicromapUsage, UsageCounts};
use crate::model::micromap_objects::{
    AllocationCallbacks, MicromapBuildSizesInfo, MicromapList, MicromapVersionInfo,
};
use crate::model::names::{StructureType, Value};
use crate::model::Handle;
use crate::scene::args::{AddressArg, HandleArg};
use crate::scene::format::{
    AccelerationStructureCreateInfo2Desc, AddressRangeDesc, AllocationCallbacksDesc, ChainStruct,
    CommandBufferArg, Contents, InlineCommandBuffer, MicromapVersionInfoDesc, OtherStruct, Piece,
    SizesInfoDesc, UsageDesc,
};
use crate::scene::{ObjectKind, DEVICE_HANDLE};

mod calls;
mod generated;

/// How a writer names what the model holds as numbers.
pub trait Names {
    /// The scene's form of `handle`, an object of `kind`: its name where
    /// the run named it, else the number (0 is `null`).
    fn handle(&self, kind: ObjectKind, handle: Handle) -> HandleArg;
    /// The scene's form of `address`: in a named buffer or host block, or
    /// the number (0 is `null`).
    fn address(&self, address: u64) -> AddressArg;
    /// The name of an object a call creates (`pMicromap`): its name where
    /// the run named it, else one made from the handle.
    fn created(&self, kind: ObjectKind, handle: Handle) -> String {
        match self.handle(kind, handle) {
            HandleArg::Name(name) => name,
            _ => format!("{}-{handle:#x}", kind.type_name()),
        }
    }
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

/// The scene's `device`: left out for the scene's own device.
pub(crate) fn device_arg(device: Handle) -> HandleArg {
    match device {
        DEVICE_HANDLE => HandleArg::Omitted,
        0 => HandleArg::Null,
        raw => HandleArg::Raw(raw),
    }
}

/// The scene's command buffer: by its name where the run named it (its
/// state is then the one `commandBuffers` declares), else described inline.
pub(crate) fn command_buffer_arg(
    command_buffer: &CommandBuffer,
    names: &dyn Names,
) -> CommandBufferArg {
    if let HandleArg::Name(name) = names.handle(ObjectKind::CommandBuffer, command_buffer.handle) {
        return CommandBufferArg::Name(name);
    }
    CommandBufferArg::Inline(InlineCommandBuffer {
        handle: Some(command_buffer.handle),
        recording: command_buffer.recording,
        queue_flags: Some(Value::new(i64::from(command_buffer.queue_flags))),
        in_render_pass: command_buffer.in_render_pass,
        in_video_coding: command_buffer.in_video_coding,
        suspended: command_buffer.suspended,
    })
}

/// The scene form of `VkAllocationCallbacks`.
pub(crate) fn allocator_desc(callbacks: &AllocationCallbacks) -> AllocationCallbacksDesc {
    AllocationCallbacksDesc {
        pfn_allocation: callbacks.pfn_allocation,
        pfn_reallocation: callbacks.pfn_reallocation,
        pfn_free: callbacks.pfn_free,
        pfn_internal_allocation: callbacks.pfn_internal_allocation,
        pfn_internal_free: callbacks.pfn_internal_free,
    }
}

/// `micromapCount` (where the resolver would not take it from the array's
/// length) and `pMicromaps`.
pub(crate) fn micromap_list_desc(
    list: &MicromapList,
    names: &dyn Names,
) -> (Option<u32>, Option<Vec<HandleArg>>) {
    let handles = list.handles.as_ref().map(|handles| {
        handles
            .iter()
            .map(|&h| names.handle(ObjectKind::Micromap, h))
            .collect()
    });
    let implied = list.handles.as_ref().map_or(0, Vec::len);
    let count = (u32::try_from(implied) != Ok(list.count)).then_some(list.count);
    (count, handles)
}

/// The scene's sType where it is not `default`.
fn s_type_desc(s_type: i32, default: i32) -> Option<Value<StructureType>> {
    (s_type != default).then(|| Value::new(i64::from(s_type)))
}

/// The scene form of a sizes info as handed in (its sType and chain).
pub(crate) fn sizes_info_desc(info: &Option<MicromapBuildSizesInfo>) -> Option<SizesInfoDesc> {
    info.as_ref().map(|info| SizesInfoDesc {
        s_type: s_type_desc(info.s_type, MicromapBuildSizesInfo::default().s_type),
        p_next: info.next.iter().copied().map(chain_entry).collect(),
    })
}

/// The scene form of `VkMicromapVersionInfoEXT`, the version data as hex.
pub(crate) fn version_info_desc(
    info: &Option<MicromapVersionInfo>,
) -> Option<MicromapVersionInfoDesc> {
    info.as_ref().map(|info| MicromapVersionInfoDesc {
        s_type: s_type_desc(info.s_type, MicromapVersionInfo::default().s_type),
        p_next: info.next.iter().copied().map(chain_entry).collect(),
        p_version_data: info
            .version_data
            .as_ref()
            .map(|bytes| bytes.iter().map(|b| format!("{b:02x}")).collect()),
    })
}

/// The scene form of `VkAccelerationStructureCreateInfo2KHR`.
pub(crate) fn create_info2_desc(
    info: &AccelerationStructureCreateInfo2,
    names: &dyn Names,
) -> AccelerationStructureCreateInfo2Desc {
    AccelerationStructureCreateInfo2Desc {
        s_type: s_type_desc(
            info.s_type,
            AccelerationStructureCreateInfo2::default().s_type,
        ),
        p_next: info.next.iter().copied().map(chain_entry).collect(),
        create_flags: Value::new(i64::from(info.create_flags)),
        address_range: AddressRangeDesc {
            address: names.address(info.address),
            size: info.size,
        },
        address_flags: Value::new(i64::from(info.address_flags)),
        ty: Value::new(i64::from(info.ty)),
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
    fn a_written_call_names_its_objects_and_leaves_the_scene_device_out() {
        use crate::model::calls;
        let call = calls::Call::DestroyMicromap(calls::DestroyMicromap {
            device: DEVICE_HANDLE,
            micromap: 0x33_0001,
            allocator: None,
        });
        let json = crate::scene::format::Call::written(&call, &OneOfEach)
            .json()
            .unwrap()
            .unwrap();
        assert_eq!(
            json,
            serde_json::json!({"call": "vkDestroyMicromapEXT", "micromap": "omm", "pAllocator": null})
        );
        // A created object the run did not name gets a name from its handle.
        assert_eq!(
            OneOfEach.created(ObjectKind::AccelerationStructure, 0xa5_0002),
            "VkAccelerationStructureKHR-0xa50002"
        );
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
