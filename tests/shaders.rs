//! SPIR-V the test applications run, assembled at development time so
//! that neither the build nor CI needs a shader compiler.

/// `shaders/copy_words.spvasm` assembled for Vulkan 1.1: a compute shader
/// (local size 16) whose invocation `i` copies word `i` of the storage
/// buffer at binding 0 to word `i` of the one at binding 1. After editing
/// the source, regenerate with Debian's spirv-tools:
///
/// ```text
/// spirv-as --target-env vulkan1.1 shaders/copy_words.spvasm -o copy_words.spv
/// od -An -v -tx4 copy_words.spv
/// ```
#[rustfmt::skip]
pub const COPY_WORDS: [u32; 145] = [
    0x07230203, 0x00010300, 0x00070000, 0x00000016, 0x00000000, 0x00020011,
    0x00000001, 0x0003000e, 0x00000000, 0x00000001, 0x0006000f, 0x00000005,
    0x00000001, 0x6e69616d, 0x00000000, 0x00000002, 0x00060010, 0x00000001,
    0x00000011, 0x00000010, 0x00000001, 0x00000001, 0x00040047, 0x00000002,
    0x0000000b, 0x0000001c, 0x00040047, 0x00000003, 0x00000006, 0x00000004,
    0x00050048, 0x00000004, 0x00000000, 0x00000023, 0x00000000, 0x00030047,
    0x00000004, 0x00000002, 0x00040047, 0x00000005, 0x00000022, 0x00000000,
    0x00040047, 0x00000005, 0x00000021, 0x00000000, 0x00030047, 0x00000005,
    0x00000018, 0x00040047, 0x00000006, 0x00000022, 0x00000000, 0x00040047,
    0x00000006, 0x00000021, 0x00000001, 0x00020013, 0x00000007, 0x00030021,
    0x00000008, 0x00000007, 0x00040015, 0x00000009, 0x00000020, 0x00000000,
    0x0004002b, 0x00000009, 0x0000000a, 0x00000000, 0x00040017, 0x0000000b,
    0x00000009, 0x00000003, 0x00040020, 0x0000000c, 0x00000001, 0x0000000b,
    0x00040020, 0x0000000d, 0x00000001, 0x00000009, 0x0004003b, 0x0000000c,
    0x00000002, 0x00000001, 0x0003001d, 0x00000003, 0x00000009, 0x0003001e,
    0x00000004, 0x00000003, 0x00040020, 0x0000000e, 0x0000000c, 0x00000004,
    0x00040020, 0x0000000f, 0x0000000c, 0x00000009, 0x0004003b, 0x0000000e,
    0x00000005, 0x0000000c, 0x0004003b, 0x0000000e, 0x00000006, 0x0000000c,
    0x00050036, 0x00000007, 0x00000001, 0x00000000, 0x00000008, 0x000200f8,
    0x00000010, 0x00050041, 0x0000000d, 0x00000011, 0x00000002, 0x0000000a,
    0x0004003d, 0x00000009, 0x00000012, 0x00000011, 0x00060041, 0x0000000f,
    0x00000013, 0x00000005, 0x0000000a, 0x00000012, 0x0004003d, 0x00000009,
    0x00000014, 0x00000013, 0x00060041, 0x0000000f, 0x00000015, 0x00000006,
    0x0000000a, 0x00000012, 0x0003003e, 0x00000015, 0x00000014, 0x000100fd,
    0x00010038,
];

#[cfg(test)]
mod tests {
    use super::COPY_WORDS;
    use std::process::Command;

    /// The committed words are the committed assembly, where spirv-tools
    /// is installed (it is optional: CI runs without it).
    #[test]
    fn copy_words_is_its_assembly() {
        let source = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/copy_words.spvasm");
        let out = std::env::temp_dir().join(format!("copy_words.{}.spv", std::process::id()));
        let assembled = Command::new("spirv-as")
            .args(["--target-env", "vulkan1.1", source, "-o"])
            .arg(&out)
            .status();
        match assembled {
            Err(e) => {
                eprintln!("skipping: spirv-as (Debian: spirv-tools) did not start: {e}");
                return;
            }
            Ok(status) => assert!(status.success(), "spirv-as {source} failed ({status})"),
        }
        let bytes = std::fs::read(&out).expect("reading the assembled module");
        let _ = std::fs::remove_file(&out);
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes(w.try_into().expect("four bytes")))
            .collect();
        assert_eq!(words, COPY_WORDS, "regenerate COPY_WORDS from {source}");
    }
}
