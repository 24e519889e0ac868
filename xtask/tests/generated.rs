//! The committed generated files are what the registry in
//! `../shared/vulkan-registry` generates, byte for byte.

use std::path::{Path, PathBuf};

fn registry() -> Option<PathBuf> {
    xtask::testing::shared_registry()
}

#[test]
fn committed_files_are_up_to_date() {
    let Some(registry) = registry() else { return };
    if let Err(e) = xtask::check_generated(&registry, &xtask::workspace_root()) {
        panic!("{e}");
    }
}

fn link(from: &Path, to: &Path) {
    std::os::unix::fs::symlink(from, to).expect("symlink into the temporary registry");
}

/// Without the annotations file (as with a Vulkan SDK's registry directory)
/// the selection and the texts are the same; gating falls back to what
/// vk.xml tells, which agrees with the specification's ifdef gating for most
/// VUIDs, and the Khronos-layer column is unknown.
#[test]
fn registry_without_annotations_selects_the_same_vuids() {
    let Some(registry) = registry() else { return };
    let dir = std::env::temp_dir().join(format!("ommcheck-registry-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for file in ["vk.xml", "validusage.json"] {
        let target = dir.join(file);
        let _ = std::fs::remove_file(&target);
        link(&registry.join(file), &target);
    }
    let bare = xtask::catalog::select(&dir).expect("bare registry selects");
    let annotated = xtask::catalog::select(&registry).expect("annotated registry selects");
    std::fs::remove_dir_all(&dir).unwrap();

    assert!(bare.gating_source.starts_with("derived from vk.xml"));
    assert_eq!(bare.entries.len(), annotated.entries.len());
    let mut agree = 0;
    for (b, a) in bare.entries.iter().zip(&annotated.entries) {
        assert_eq!(b.id, a.id);
        assert_eq!(b.text, a.text);
        assert_eq!(b.khronos_layer_checks, None);
        assert_eq!(b.extensions, a.derived_extensions);
        if b.extensions == a.extensions {
            agree += 1;
        }
    }
    eprintln!(
        "derived gating agrees with the specification's for {agree} of {}",
        bare.entries.len()
    );
    // Measured on 1.4.360: 512 of 574. The rest are gated by ifdef blocks whose
    // text names no extension symbol (e.g. KHR's "micromap arrays" rules).
    assert!(agree >= 500, "derived gating agrees for only {agree}");
}

/// The structure generator describes only structures whose every member has
/// a generated form; one with an array it has no form for is refused,
/// naming the member, rather than generated wrong. The usage-count arrays
/// have a form.
#[test]
fn a_structure_with_an_array_is_refused_by_name() {
    let Some(registry) = registry() else { return };
    let vk = xtask::registry::VkXml::load(&registry.join("vk.xml")).expect("vk.xml loads");
    let spec = |vk_name| xtask::structs::StructSpec {
        vk: vk_name,
        rust: "Test",
        ..xtask::structs::BASE
    };
    let error = match xtask::structs::fields(&vk, &spec("VkMicromapVersionInfoEXT")) {
        Ok(_) => panic!("VkMicromapVersionInfoEXT has a byte array; it must not be generated"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.contains("VkMicromapVersionInfoEXT.pVersionData"),
        "{error}"
    );
    let usage_counts = xtask::structs::fields(&vk, &spec("VkMicromapBuildInfoEXT"))
        .expect("the usage-count arrays have a form");
    assert!(usage_counts
        .iter()
        .any(|f| f.form == xtask::structs::Form::UsageCounts));
    assert!(error.contains("write the structure by hand"), "{error}");
    // An array of described structures needs its `elements` entry.
    let error =
        match xtask::structs::fields(&vk, &spec("VkAccelerationStructureBuildGeometryInfoKHR")) {
            Ok(_) => panic!("pGeometries has no elements entry; it must not be generated"),
            Err(e) => e.to_string(),
        };
    assert!(error.contains("pGeometries"), "{error}");
    // Every structure STRUCTS lists has a form for each member.
    for spec in xtask::structs::STRUCTS {
        assert!(xtask::structs::fields(&vk, spec).is_ok(), "{}", spec.vk);
    }
}

/// The command generator refuses, by name, a parameter whose type gives it
/// no form (it must be given one in COMMANDS); a count that only gives an
/// array's length goes with the array, while `dataSize`, the length of
/// data the command only looks at as an address, stays.
#[test]
fn a_command_parameter_without_a_form_is_refused_by_name() {
    let Some(registry) = registry() else { return };
    let vk = xtask::registry::VkXml::load(&registry.join("vk.xml")).expect("vk.xml loads");
    let spec = |vk_name| xtask::commands::CommandSpec {
        vk: vk_name,
        rust: "Test",
        ..xtask::commands::BASE
    };
    let error = match xtask::commands::args(&vk, &spec("vkGetDeviceMicromapCompatibilityEXT")) {
        Ok(_) => panic!("pVersionInfo has no generated form; it must not be generated"),
        Err(e) => e.to_string(),
    };
    assert!(error.contains("pVersionInfo"), "{error}");
    let names = |vk_name| -> Vec<String> {
        xtask::commands::args(&vk, &spec(vk_name))
            .expect("a command of plain parameters")
            .into_iter()
            .map(|a| a.name)
            .collect()
    };
    assert_eq!(names("vkCmdBuildMicromapsEXT"), ["commandBuffer", "pInfos"]);
    assert!(names("vkWriteAccelerationStructuresPropertiesKHR").contains(&"dataSize".to_string()));
    // Every command COMMANDS lists has a form for each parameter.
    for spec in xtask::commands::COMMANDS {
        assert!(xtask::commands::args(&vk, spec).is_ok(), "{}", spec.vk);
    }
}
