//! The serialized header a deserialization reads (`VkCopyMemoryToAccelerationStructureInfoKHR::src`
//! of `vkCmdCopyMemoryToAccelerationStructureKHR` and
//! `vkCopyMemoryToAccelerationStructureKHR`): the blocks of a bottom-level
//! structure's header and the opacity micromaps they name (11583, 11584,
//! 11585).
//!
//! The header of a bottom-level acceleration structure, as the
//! specification defines it under `vkCmdCopyAccelerationStructureToMemoryKHR`:
//! the driver UUID and the compatibility UUID (16 bytes each), the
//! serialized and the deserialized size (8 bytes each), then a 64-bit value
//! whose high 32 bits are 0xFFFFFFFF (a block-based format) and whose low 32
//! bits count the blocks that follow; each block is a 32-bit type, 32
//! reserved bits, a 64-bit count of addresses and that many 64-bit buffer
//! device addresses.

use ommcheck_vuids::vuid::VkCopyMemoryToAccelerationStructureInfoKHR as from_memory_info;
use ommcheck_vuids::Vuid;

use crate::checks::common;
use crate::checks::Ctx;
use crate::model::accel::{
    CopyMemoryToAccelerationStructureInfo, ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
    ACCELERATION_STRUCTURE_TYPE_GENERIC, ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
};
use crate::report::RuleId;
use crate::state::State;

/// The rules this module decides, all of them from the header's bytes.
pub(crate) const RULES: [Vuid; 3] = [
    from_memory_info::src_11583,
    from_memory_info::dst_11584,
    from_memory_info::dst_11585,
];

/// Where the packed block count lies in the header.
const BLOCK_COUNT_OFFSET: usize = 2 * 16 + 2 * 8;
/// The high 32 bits of the packed block count of a block-based header.
const BLOCK_FORMAT_MARKER: u32 = 0xFFFF_FFFF;
/// `VK_ACCELERATION_STRUCTURE_SERIALIZED_BLOCK_TYPE_OPACITY_MICROMAP_KHR`,
/// the one value of `VkAccelerationStructureSerializedBlockTypeKHR`.
const BLOCK_TYPE_OPACITY_MICROMAP: u32 = 0;
/// A block's type, reserved word and address count.
const BLOCK_HEADER_SIZE: usize = 4 + 4 + 8;

/// One block of the header, as far as the bytes the checker has reach.
struct Block<'a> {
    /// Byte offset of the block in the header.
    offset: usize,
    ty: u32,
    /// The addresses that lie inside the bytes (up to the declared count).
    addresses: &'a [u8],
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let word = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(word.try_into().ok()?))
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    let word = bytes.get(at..at.checked_add(8)?)?;
    Some(u64::from_le_bytes(word.try_into().ok()?))
}

/// The blocks of a block-based header, None for a header without the
/// block-based marker. Blocks past the end of `bytes` are not read; no
/// count read from the bytes sizes an allocation.
fn blocks(bytes: &[u8]) -> Option<Vec<Block<'_>>> {
    let packed = u64_at(bytes, BLOCK_COUNT_OFFSET)?;
    if (packed >> 32) as u32 != BLOCK_FORMAT_MARKER {
        return None;
    }
    let count = packed as u32;
    let mut out = Vec::new();
    let mut at = BLOCK_COUNT_OFFSET + 8;
    for _ in 0..count {
        let (Some(ty), Some(addresses)) = (u32_at(bytes, at), u64_at(bytes, at + 8)) else {
            break;
        };
        let start = at + BLOCK_HEADER_SIZE;
        let wanted = usize::try_from(addresses)
            .ok()
            .and_then(|n| n.checked_mul(8))
            .unwrap_or(usize::MAX);
        let end = start.saturating_add(wanted).min(bytes.len());
        let inside = bytes.get(start..end).unwrap_or_default();
        out.push(Block {
            offset: at,
            ty,
            addresses: &inside[..inside.len() - inside.len() % 8],
        });
        if end < start.saturating_add(wanted) {
            break;
        }
        at = end;
    }
    Some(out)
}

/// What `address` is to 11585.
#[derive(Clone, Copy, PartialEq, Eq)]
enum HeaderAddress {
    /// What `vkGetBufferDeviceAddress` returned for the buffer of a KHR
    /// opacity micromap of the device that executes the command.
    OnThisDevice,
    /// The same, but the micromap or its buffer belongs to another
    /// `VkDevice`: the command's device has no such micromap.
    OnAnotherDevice,
    /// No micromap's buffer has this address.
    NoMicromap,
}

/// What `address` is: the buffer address of which known KHR opacity
/// micromap, on which device.
fn header_address(state: &State, address: u64) -> HeaderAddress {
    let foreign = |handle| state.other_device_objects.contains(&handle);
    let mut found = HeaderAddress::NoMicromap;
    for (handle, s) in &state.acceleration_structures {
        if s.ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
            continue;
        }
        // Created from a buffer, or from an address range: the buffer
        // holding the range's start.
        let buffer = if s.created_with_2 {
            s.address_range.and_then(|(start, _)| {
                state
                    .buffers_at(start)
                    .find(|(_, b)| b.device_address.is_some())
            })
        } else {
            state.buffers.get(&s.buffer).map(|b| (s.buffer, b))
        };
        let Some((buffer_handle, buffer)) = buffer else {
            continue;
        };
        if buffer.device_address != Some(address) {
            continue;
        }
        if foreign(*handle) || foreign(buffer_handle) {
            found = HeaderAddress::OnAnotherDevice;
        } else {
            return HeaderAddress::OnThisDevice;
        }
    }
    found
}

/// The rules on the serialized header at `info.src` (host memory when
/// `host`), for a destination created bottom-level (or generic, when the
/// header says it is block-based).
pub(crate) fn check(ctx: &mut Ctx<'_>, host: bool, info: &CopyMemoryToAccelerationStructureInfo) {
    let (Some(state), Some(host_memory)) = (ctx.state, ctx.host()) else {
        return;
    };
    if !ctx.contents {
        return;
    }
    let Some(dst_type) = state.acceleration_structures.get(&info.dst).map(|s| s.ty) else {
        return;
    };
    if dst_type != ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL
        && dst_type != ACCELERATION_STRUCTURE_TYPE_GENERIC
    {
        return;
    }
    let bytes = if host {
        host_memory.bytes_from(info.src)
    } else {
        state.device_bytes_from(info.src)
    };
    let Some(bytes) = bytes else {
        // A generic destination may receive a top-level header: only a
        // bottom-level one says for sure that these rules apply.
        if dst_type == ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL {
            let rules = RULES.map(RuleId::from);
            common::unreadable(ctx, host, info.src, &rules, "pInfo->src");
        }
        return;
    };
    let Some(blocks) = blocks(bytes) else {
        return;
    };
    let micromap_feature = ctx.device.features.micromap_khr;
    for (i, block) in blocks.iter().enumerate() {
        let at = || format!("pInfo->src (header block {i}, byte {})", block.offset);
        ctx.require(
            block.ty == BLOCK_TYPE_OPACITY_MICROMAP,
            from_memory_info::src_11583,
            at,
            || format!("the block's type {} is not a VkAccelerationStructureSerializedBlockTypeKHR value (the one value is VK_ACCELERATION_STRUCTURE_SERIALIZED_BLOCK_TYPE_OPACITY_MICROMAP_KHR, 0)", block.ty),
        );
        if block.ty != BLOCK_TYPE_OPACITY_MICROMAP {
            continue;
        }
        ctx.require(
            micromap_feature,
            from_memory_info::dst_11584,
            at,
            || "the block's type is VK_ACCELERATION_STRUCTURE_SERIALIZED_BLOCK_TYPE_OPACITY_MICROMAP_KHR, but the VkPhysicalDeviceOpacityMicromapFeaturesKHR::micromap feature is not enabled".to_string(),
        );
        for (k, word) in block.addresses.chunks_exact(8).enumerate() {
            let address = u64::from_le_bytes(word.try_into().unwrap_or_default());
            // NULL stands for a geometry without a micromap: the
            // specification has the application keep the NULLs an
            // implementation wrote.
            let found = if address == 0 {
                HeaderAddress::OnThisDevice
            } else {
                header_address(state, address)
            };
            ctx.require(
                found == HeaderAddress::OnThisDevice,
                from_memory_info::dst_11585,
                || format!("pInfo->src (header block {i}, address {k})"),
                || match found {
                    HeaderAddress::OnAnotherDevice => format!("{address:#x} is the device address of the buffer of a KHR opacity micromap of another VkDevice, not of the device that executes the command"),
                    _ => format!("{address:#x} is not the device address of the buffer of any KHR opacity micromap the checker knows"),
                },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(blocks: &[(u32, &[u64])], declared: u32) -> Vec<u8> {
        let mut out = vec![0u8; BLOCK_COUNT_OFFSET];
        out.extend_from_slice(
            &(u64::from(BLOCK_FORMAT_MARKER) << 32 | u64::from(declared)).to_le_bytes(),
        );
        for (ty, addresses) in blocks {
            out.extend_from_slice(&ty.to_le_bytes());
            out.extend_from_slice(&0u32.to_le_bytes());
            out.extend_from_slice(&(addresses.len() as u64).to_le_bytes());
            for a in *addresses {
                out.extend_from_slice(&a.to_le_bytes());
            }
        }
        out
    }

    #[test]
    fn blocks_are_read_as_the_specification_lays_them_out() {
        let bytes = header(&[(0, &[0x1000, 0]), (7, &[])], 2);
        let blocks = blocks(&bytes).expect("block-based");
        assert_eq!(blocks.len(), 2);
        assert_eq!((blocks[0].offset, blocks[0].ty), (56, 0));
        assert_eq!(blocks[0].addresses.len(), 16);
        assert_eq!((blocks[1].offset, blocks[1].ty), (56 + 16 + 16, 7));
    }

    #[test]
    fn a_header_without_the_marker_has_no_blocks() {
        let mut bytes = header(&[], 0);
        bytes[BLOCK_COUNT_OFFSET + 7] = 0;
        assert!(blocks(&bytes).is_none());
    }

    #[test]
    fn counts_past_the_bytes_read_only_what_is_there() {
        // The header declares 1000 blocks, the first claims 2^40 addresses:
        // only the one address present is read, nothing is sized by them.
        let mut bytes = header(&[(0, &[0x2000])], 1000);
        bytes[BLOCK_COUNT_OFFSET + 8 + 8..BLOCK_COUNT_OFFSET + 8 + 16]
            .copy_from_slice(&(1u64 << 40).to_le_bytes());
        let blocks = blocks(&bytes).expect("block-based");
        assert_eq!(blocks.len(), 1);
        assert_eq!(blocks[0].addresses, 0x2000u64.to_le_bytes());
    }
}
