//! A scene can express every call a micromap VUID's parent names: the
//! parent itself where it is a command, and where it is a structure every
//! command that takes it (through its parameters, their members, and the
//! structures that extend them in pNext), as vk.xml defines them. The few
//! calls scenes do not express are listed with the reason.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::PathBuf;

use ommcheck::vuids::{ParentKind, Vuid};
use vk_parse::{Command, RegistryChild, TypeMember, TypeMemberMarkup, TypeSpec, TypesChild};

/// Calls that take a micromap VUID's parent structure but that scenes do not
/// express, each with the reason no micromap rule is lost.
const NOT_EXPRESSED: &[(&str, &str)] = &[
    (
        "vkGetPhysicalDeviceFeatures2",
        "a query the implementation fills in; the feature structures' rules are checked where an application passes them, vkCreateDevice, which scenes express",
    ),
    (
        "vkCreateRenderPass2",
        "VkMemoryBarrier2 extends VkSubpassDependency2 there; render passes are outside what ommcheck models, so its 07454, 07457, 07458 and 11541 are checked on vkCmdPipelineBarrier2, vkCmdSetEvent2 and vkCmdWaitEvents2 only",
    ),
    (
        "vkGetPipelineIndirectMemoryRequirementsNV",
        "the VK_NV_device_generated_commands_compute size query of a compute pipeline; the VkComputePipelineCreateInfo rules are checked on vkCreateComputePipelines only",
    ),
];

/// Parent structures no command takes as a parameter: applications write
/// them into memory that these commands read.
const READ_FROM_MEMORY: &[(&str, &[&str])] = &[
    (
        "VkAccelerationStructureInstanceKHR",
        &[
            "vkCmdBuildAccelerationStructuresKHR",
            "vkCmdBuildAccelerationStructuresIndirectKHR",
            "vkBuildAccelerationStructuresKHR",
        ],
    ),
    (
        "VkClusterAccelerationStructureBuildTriangleClusterInfoNV",
        &["vkCmdBuildClusterAccelerationStructureIndirectNV"],
    ),
    (
        "VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV",
        &["vkCmdBuildClusterAccelerationStructureIndirectNV"],
    ),
];

fn registry() -> Option<PathBuf> {
    xtask::testing::shared_registry().map(|dir| dir.join("vk.xml"))
}

/// For each command of vk.xml (aliases resolved to the commands they
/// name), the structure types it takes, transitively through members and
/// through the structures that extend a taken one.
fn structures_by_command(path: &std::path::Path) -> BTreeMap<String, BTreeSet<String>> {
    let (registry, _) = vk_parse::parse_file(path).expect("vk.xml parses");
    let mut members: HashMap<String, Vec<String>> = HashMap::new();
    let mut extended_by: HashMap<String, Vec<String>> = HashMap::new();
    let mut commands: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut aliases = Vec::new();
    for child in registry.0 {
        match child {
            RegistryChild::Types(block) => {
                for child in block.children {
                    let TypesChild::Type(ty) = child else {
                        continue;
                    };
                    let (Some(name), TypeSpec::Members(list)) = (ty.name.clone(), &ty.spec) else {
                        continue;
                    };
                    let types = list
                        .iter()
                        .filter_map(|m| match m {
                            TypeMember::Definition(d) => Some(d),
                            _ => None,
                        })
                        .flat_map(|d| &d.markup)
                        .filter_map(|m| match m {
                            TypeMemberMarkup::Type(t) => Some(t.clone()),
                            _ => None,
                        });
                    members.entry(name.clone()).or_default().extend(types);
                    for base in ty.structextends.iter().flat_map(|s| s.split(',')) {
                        extended_by
                            .entry(base.to_string())
                            .or_default()
                            .push(name.clone());
                    }
                }
            }
            RegistryChild::Commands(block) => {
                for command in block.children {
                    match command {
                        Command::Definition(d) => {
                            let params = d
                                .params
                                .iter()
                                .filter_map(|p| p.definition.type_name.clone())
                                .collect();
                            commands.insert(d.proto.name.clone(), params);
                        }
                        Command::Alias { name, alias } => aliases.push((name, alias)),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
    for (name, alias) in aliases {
        if let Some(params) = commands.get(&alias).cloned() {
            commands.insert(name, params);
        }
    }
    commands
        .into_iter()
        .map(|(command, params)| {
            let mut seen = BTreeSet::new();
            let mut stack = params;
            while let Some(ty) = stack.pop() {
                if !seen.insert(ty.clone()) {
                    continue;
                }
                stack.extend(members.get(&ty).into_iter().flatten().cloned());
                stack.extend(extended_by.get(&ty).into_iter().flatten().cloned());
            }
            (command, seen)
        })
        .collect()
}

#[test]
fn scenes_express_every_call_a_micromap_parent_names() {
    let Some(path) = registry() else { return };
    let by_command = structures_by_command(&path);
    let expressed: BTreeSet<&str> = ommcheck::scene::format::CALL_NAMES
        .iter()
        .copied()
        .chain(ommcheck::scene::format::work_call_names())
        .collect();
    let not_expressed: BTreeMap<&str, &str> = NOT_EXPRESSED.iter().copied().collect();
    // The KHR, EXT and other suffixed aliases of core commands take the same
    // parameters; a scene names the core command.
    let core_of = |call: &str| {
        ["KHR", "EXT"]
            .iter()
            .find_map(|s| call.strip_suffix(s))
            .filter(|core| by_command.contains_key(*core) && expressed.contains(core))
            .map(str::to_string)
    };
    let mut missing = BTreeMap::new();
    let mut used_exceptions = BTreeSet::new();
    for vuid in Vuid::all() {
        let info = vuid.info();
        let mut calls: Vec<String> = match info.parent_kind {
            ParentKind::Command => by_command
                .keys()
                .filter(|c| c.as_str() == info.parent)
                .cloned()
                .collect(),
            ParentKind::Struct => by_command
                .iter()
                .filter(|(_, types)| types.contains(info.parent))
                .map(|(c, _)| c.clone())
                .collect(),
            // SPIR-V rules are expressed through shader modules.
            _ => continue,
        };
        if calls.is_empty() {
            let readers = READ_FROM_MEMORY.iter().find(|(s, _)| *s == info.parent);
            calls.extend(
                readers
                    .into_iter()
                    .flat_map(|(_, c)| c.iter().map(|c| c.to_string())),
            );
        }
        assert!(
            !calls.is_empty(),
            "{}: no command takes {}",
            info.id,
            info.parent
        );
        for call in calls {
            if expressed.contains(call.as_str()) || core_of(&call).is_some() {
                continue;
            }
            let named = ["KHR", "EXT"]
                .iter()
                .find_map(|s| call.strip_suffix(s))
                .unwrap_or(&call);
            if let Some((name, _)) = not_expressed.get_key_value(named) {
                used_exceptions.insert(*name);
                continue;
            }
            missing
                .entry(call)
                .or_insert_with(BTreeSet::new)
                .insert(info.parent);
        }
    }
    assert!(
        missing.is_empty(),
        "calls that take a micromap VUID's parent but that scenes do not express (call: parents): {missing:#?}"
    );
    let stale: Vec<&str> = not_expressed
        .keys()
        .filter(|c| !used_exceptions.contains(*c))
        .copied()
        .collect();
    assert!(stale.is_empty(), "exceptions no parent needs: {stale:?}");
}
