//! The loader–layer interface (`vk_layer.h`), which ash does not declare,
//! and the walk that finds the loader's link information in a create info.

#![allow(unsafe_code)]

use std::collections::HashSet;
use std::ffi::{c_char, c_void};

use ash::vk;

/// `LAYER_NEGOTIATE_INTERFACE_STRUCT`, the sType of [`NegotiateLayerInterface`].
pub const LAYER_NEGOTIATE_INTERFACE_STRUCT: i32 = 1;
/// The loader–layer interface version this layer implements.
pub const LAYER_INTERFACE_VERSION: u32 = 2;
/// `VK_LAYER_LINK_INFO`: the `function` of a create info carrying the next layer's link.
pub const LAYER_LINK_INFO: i32 = 0;
/// The most structures walked in a create info's pNext chain.
const MAX_CHAIN: usize = 64;

/// `vkGetPhysicalDeviceProcAddr`, which a layer may export through negotiation.
pub type PfnGetPhysicalDeviceProcAddr =
    unsafe extern "system" fn(vk::Instance, *const c_char) -> vk::PFN_vkVoidFunction;

/// `VkNegotiateLayerInterface`.
#[repr(C)]
pub struct NegotiateLayerInterface {
    pub s_type: i32,
    pub p_next: *mut c_void,
    pub loader_layer_interface_version: u32,
    pub pfn_get_instance_proc_addr: Option<vk::PFN_vkGetInstanceProcAddr>,
    pub pfn_get_device_proc_addr: Option<vk::PFN_vkGetDeviceProcAddr>,
    pub pfn_get_physical_device_proc_addr: Option<PfnGetPhysicalDeviceProcAddr>,
}

/// `VkLayerInstanceLink`: one layer's place in the instance call chain.
#[repr(C)]
pub struct LayerInstanceLink {
    pub p_next: *mut LayerInstanceLink,
    pub pfn_next_get_instance_proc_addr: Option<vk::PFN_vkGetInstanceProcAddr>,
    pub pfn_next_get_physical_device_proc_addr: Option<PfnGetPhysicalDeviceProcAddr>,
}

/// The union of `VkLayerInstanceCreateInfo`; its largest member is a pair of
/// function pointers (`layerDevice`), so it is two pointers wide.
#[repr(C)]
#[derive(Clone, Copy)]
pub union LayerInstanceCreateInfoUnion {
    pub p_layer_info: *mut LayerInstanceLink,
    pub layer_device: [*const c_void; 2],
}

/// `VkLayerInstanceCreateInfo` (sType `VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO`).
#[repr(C)]
pub struct LayerInstanceCreateInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub function: i32,
    pub u: LayerInstanceCreateInfoUnion,
}

/// `VkLayerDeviceLink`: one layer's place in the device call chain.
#[repr(C)]
pub struct LayerDeviceLink {
    pub p_next: *mut LayerDeviceLink,
    pub pfn_next_get_instance_proc_addr: Option<vk::PFN_vkGetInstanceProcAddr>,
    pub pfn_next_get_device_proc_addr: Option<vk::PFN_vkGetDeviceProcAddr>,
}

/// The union of `VkLayerDeviceCreateInfo`.
#[repr(C)]
#[derive(Clone, Copy)]
pub union LayerDeviceCreateInfoUnion {
    pub p_layer_info: *mut LayerDeviceLink,
    pub pfn_set_device_loader_data: *const c_void,
}

/// `VkLayerDeviceCreateInfo` (sType `VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO`).
#[repr(C)]
pub struct LayerDeviceCreateInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub function: i32,
    pub u: LayerDeviceCreateInfoUnion,
}

/// The first structure in the chain from `next` with `s_type` and
/// `function == VK_LAYER_LINK_INFO`, walking at most [`MAX_CHAIN`]
/// structures and never one address twice.
///
/// # Safety
/// Every non-NULL pNext in the chain must point to a structure that starts
/// with sType and pNext; one with `s_type` must be a `T` whose third member
/// is the `function` (as both loader create infos are).
unsafe fn find_link_info<T>(mut next: *const c_void, s_type: vk::StructureType) -> *mut T {
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: the caller guarantees a structure starting with sType and pNext.
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == s_type {
            // SAFETY: a structure with this sType is a loader create info,
            // whose `function` follows sType and pNext.
            let function = unsafe { *next.cast::<u8>().add(2 * size_of::<usize>()).cast::<i32>() };
            if function == LAYER_LINK_INFO {
                // The loader hands the chain to each layer to advance: it
                // is declared const in VkInstanceCreateInfo, but the loader
                // built it writable.
                return next.cast_mut().cast();
            }
        }
        next = base.p_next.cast();
    }
    std::ptr::null_mut()
}

/// The next layer's `vkGetInstanceProcAddr` from the loader's link info in
/// an instance create info's chain, advancing the link so the next layer
/// finds its own. None when the chain has no link or the link is empty.
///
/// # Safety
/// `info` must be the `VkInstanceCreateInfo` the loader passed to this
/// layer's `vkCreateInstance` (its chain well formed, its link info writable).
pub unsafe fn take_instance_link(
    info: &vk::InstanceCreateInfo<'_>,
) -> Option<vk::PFN_vkGetInstanceProcAddr> {
    // SAFETY: forwarded from the caller.
    let link_info = unsafe {
        find_link_info::<LayerInstanceCreateInfo>(
            info.p_next,
            vk::StructureType::LOADER_INSTANCE_CREATE_INFO,
        )
    };
    // SAFETY: a non-NULL result points to the loader's writable create info.
    let link_info = unsafe { link_info.as_mut() }?;
    // SAFETY: with VK_LAYER_LINK_INFO, the union holds pLayerInfo.
    let link = unsafe { link_info.u.p_layer_info.as_ref() }?;
    let next = link.pfn_next_get_instance_proc_addr?;
    link_info.u.p_layer_info = link.p_next;
    Some(next)
}

/// The next layer's `vkGetInstanceProcAddr` and `vkGetDeviceProcAddr` from
/// a device create info's link info, advancing the link (see [`take_instance_link`]).
///
/// # Safety
/// As [`take_instance_link`], for the `VkDeviceCreateInfo` of `vkCreateDevice`.
pub unsafe fn take_device_link(
    info: &vk::DeviceCreateInfo<'_>,
) -> Option<(vk::PFN_vkGetInstanceProcAddr, vk::PFN_vkGetDeviceProcAddr)> {
    // SAFETY: forwarded from the caller.
    let link_info = unsafe {
        find_link_info::<LayerDeviceCreateInfo>(
            info.p_next,
            vk::StructureType::LOADER_DEVICE_CREATE_INFO,
        )
    };
    // SAFETY: a non-NULL result points to the loader's writable create info.
    let link_info = unsafe { link_info.as_mut() }?;
    // SAFETY: with VK_LAYER_LINK_INFO, the union holds pLayerInfo.
    let link = unsafe { link_info.u.p_layer_info.as_ref() }?;
    let gipa = link.pfn_next_get_instance_proc_addr?;
    let gdpa = link.pfn_next_get_device_proc_addr?;
    link_info.u.p_layer_info = link.p_next;
    Some((gipa, gdpa))
}

/// The loader's dispatch key of a dispatchable handle: the first word of
/// the object it points to. A VkPhysicalDevice shares its VkInstance's key,
/// and a VkCommandBuffer or VkQueue its VkDevice's.
///
/// # Safety
/// A non-NULL `handle` must be a dispatchable handle the loader created.
pub unsafe fn dispatch_key(handle: u64) -> Option<usize> {
    let object = std::ptr::with_exposed_provenance::<usize>(usize::try_from(handle).ok()?);
    // SAFETY: a dispatchable object starts with the loader's dispatch pointer.
    (!object.is_null()).then(|| unsafe { *object })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_match_vk_layer_h() {
        let word = size_of::<usize>();
        assert_eq!(
            size_of::<LayerInstanceCreateInfo>(),
            2 * word + 8 + 2 * word
        );
        assert_eq!(size_of::<LayerDeviceCreateInfo>(), 2 * word + 8 + word);
        assert_eq!(
            std::mem::offset_of!(LayerInstanceCreateInfo, function),
            2 * word
        );
        assert_eq!(
            std::mem::offset_of!(LayerDeviceCreateInfo, function),
            2 * word
        );
        assert_eq!(
            size_of::<NegotiateLayerInterface>(),
            2 * word + 8 + 3 * word
        );
    }

    // Which fake function ran: function addresses are not comparable
    // (Miri gives each cast of one function a new address), so the tests
    // call what was taken and look at what it did.
    std::thread_local! {
        static CALLED: std::cell::Cell<&'static str> = const { std::cell::Cell::new("") };
    }
    fn called_by(f: impl FnOnce()) -> &'static str {
        CALLED.set("");
        f();
        CALLED.get()
    }

    unsafe extern "system" fn first_gipa(
        _: vk::Instance,
        _: *const c_char,
    ) -> vk::PFN_vkVoidFunction {
        CALLED.set("first");
        None
    }
    unsafe extern "system" fn second_gipa(
        _: vk::Instance,
        _: *const c_char,
    ) -> vk::PFN_vkVoidFunction {
        CALLED.set("second");
        None
    }
    unsafe extern "system" fn gdpa(_: vk::Device, _: *const c_char) -> vk::PFN_vkVoidFunction {
        CALLED.set("gdpa");
        None
    }

    /// Calls a taken `vkGetInstanceProcAddr`; "" for none.
    fn call_gipa(f: Option<vk::PFN_vkGetInstanceProcAddr>) -> &'static str {
        called_by(|| {
            // SAFETY: the fakes above read none of their arguments.
            f.map(|f| unsafe { f(vk::Instance::null(), std::ptr::null()) });
        })
    }

    #[test]
    fn the_instance_link_is_taken_and_advanced_past_other_loader_infos() {
        let mut second = LayerInstanceLink {
            p_next: std::ptr::null_mut(),
            pfn_next_get_instance_proc_addr: Some(second_gipa),
            pfn_next_get_physical_device_proc_addr: None,
        };
        let mut first = LayerInstanceLink {
            p_next: &mut second,
            pfn_next_get_instance_proc_addr: Some(first_gipa),
            pfn_next_get_physical_device_proc_addr: None,
        };
        let mut link = LayerInstanceCreateInfo {
            s_type: vk::StructureType::LOADER_INSTANCE_CREATE_INFO,
            p_next: std::ptr::null(),
            function: LAYER_LINK_INFO,
            u: LayerInstanceCreateInfoUnion {
                p_layer_info: &mut first,
            },
        };
        // A loader info of another function (VK_LOADER_DATA_CALLBACK) first.
        let callback = LayerInstanceCreateInfo {
            s_type: vk::StructureType::LOADER_INSTANCE_CREATE_INFO,
            p_next: std::ptr::addr_of_mut!(link).cast_const().cast(),
            function: 1,
            u: LayerInstanceCreateInfoUnion {
                layer_device: [std::ptr::null(); 2],
            },
        };
        let info = vk::InstanceCreateInfo {
            p_next: std::ptr::addr_of!(callback).cast(),
            ..Default::default()
        };
        // SAFETY: a chain as the loader builds it, writable where it writes.
        let taken = unsafe { take_instance_link(&info) };
        assert_eq!(call_gipa(taken), "first");
        // SAFETY: as above; the link now names the next layer's.
        let taken = unsafe { take_instance_link(&info) };
        assert_eq!(call_gipa(taken), "second");
        // SAFETY: as above; the links are used up.
        assert!(unsafe { take_instance_link(&info) }.is_none());
    }

    #[test]
    fn the_device_link_is_taken_and_advanced() {
        let mut only = LayerDeviceLink {
            p_next: std::ptr::null_mut(),
            pfn_next_get_instance_proc_addr: Some(first_gipa),
            pfn_next_get_device_proc_addr: Some(gdpa),
        };
        let mut link = LayerDeviceCreateInfo {
            s_type: vk::StructureType::LOADER_DEVICE_CREATE_INFO,
            p_next: std::ptr::null(),
            function: LAYER_LINK_INFO,
            u: LayerDeviceCreateInfoUnion {
                p_layer_info: &mut only,
            },
        };
        let info = vk::DeviceCreateInfo {
            p_next: std::ptr::addr_of_mut!(link).cast_const().cast(),
            ..Default::default()
        };
        // SAFETY: a chain as the loader builds it, writable where it writes.
        let (gipa, device_gpa) = unsafe { take_device_link(&info) }.expect("a link");
        assert_eq!(call_gipa(Some(gipa)), "first");
        let called = called_by(|| {
            // SAFETY: the fake reads none of its arguments.
            unsafe { device_gpa(vk::Device::null(), std::ptr::null()) };
        });
        assert_eq!(called, "gdpa");
        // SAFETY: as above; the link is used up.
        assert!(unsafe { take_device_link(&info) }.is_none());
    }

    #[test]
    fn a_cyclic_chain_without_link_info_ends() {
        let mut a = vk::ValidationFeaturesEXT::default();
        let a_at = std::ptr::addr_of_mut!(a);
        let b = vk::ValidationFeaturesEXT {
            p_next: a_at.cast_const().cast(),
            ..Default::default()
        };
        // SAFETY: `a_at` points to `a`.
        unsafe { (*a_at).p_next = std::ptr::addr_of!(b).cast() };
        let info = vk::InstanceCreateInfo {
            p_next: a_at.cast_const().cast(),
            ..Default::default()
        };
        // SAFETY: every structure is valid; the chain loops.
        assert!(unsafe { take_instance_link(&info) }.is_none());
    }

    #[test]
    fn the_dispatch_key_is_the_first_word() {
        let object: [usize; 2] = [0xd15, 0];
        let handle = object.as_ptr().expose_provenance() as u64;
        // SAFETY: `handle` points to an object starting with a word.
        assert_eq!(unsafe { dispatch_key(handle) }, Some(0xd15));
        // SAFETY: NULL is not read.
        assert_eq!(unsafe { dispatch_key(0) }, None);
    }

    #[test]
    fn a_chain_without_link_info_yields_nothing() {
        let info = vk::InstanceCreateInfo::default();
        // SAFETY: an empty chain.
        assert!(unsafe { take_instance_link(&info) }.is_none());
    }
}
