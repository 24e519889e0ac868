//! The line each call of a scene starts on, for findings to point at.
//!
//! serde_json gives no positions for the values it parses, so after a
//! scene parses, one pass over its text finds them: it follows strings
//! (with their escapes) and nesting, finds the `calls` member of the
//! top-level object, and notes the line of the first character of each
//! element of that array. The text is known to be valid JSON by then; on
//! anything else the pass stops, and calls without a line have none.

/// The 1-based line on which each element of the top-level `calls` array
/// of the JSON text `text` starts, in order.
pub fn call_lines(text: &str) -> Vec<usize> {
    let bytes = text.as_bytes();
    let mut lines = Vec::new();
    let mut line = 1;
    let mut depth = 0usize;
    // The key of the top-level member being read, once its string closed.
    let mut key: Option<(usize, usize)> = None;
    // Inside the `calls` array (depth 2 is its elements' level).
    let mut in_calls = false;
    // An element may start at the next value character.
    let mut expecting_element = false;
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        if b == b'\n' {
            line += 1;
            i += 1;
            continue;
        }
        if b.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if in_calls && depth == 2 && expecting_element && b != b']' {
            lines.push(line);
            expecting_element = false;
        }
        match b {
            b'"' => {
                let start = i + 1;
                i = start;
                while i < bytes.len() && bytes[i] != b'"' {
                    if bytes[i] == b'\\' {
                        i += 1;
                    } else if bytes[i] == b'\n' {
                        line += 1;
                    }
                    i += 1;
                }
                if depth == 1 {
                    key = Some((start, i.min(bytes.len())));
                }
            }
            b'{' | b'[' => {
                depth += 1;
                if depth == 2 && b == b'[' {
                    in_calls = key.is_some_and(|(s, e)| &bytes[s..e] == b"calls");
                    expecting_element = in_calls;
                }
            }
            b'}' | b']' => {
                if depth == 2 && in_calls {
                    in_calls = false;
                }
                depth = depth.saturating_sub(1);
            }
            b',' => {
                if depth == 1 {
                    key = None;
                }
                expecting_element = in_calls && depth == 2;
            }
            _ => {}
        }
        i += 1;
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_call_has_the_line_it_starts_on() {
        let text = r#"{
  "description": "a \"calls\": [ string, { not a call",
  "buffers": [{ "name": "calls", "calls": [1, 2] }],
  "calls": [
    { "call": "vkCmdBuildMicromapsEXT",
      "pInfos": [] },

    {
      "call": "vkCmdBuildMicromapsEXT", "pInfos": [{"calls": [3]}]
    }, {"call": "x"}
  ],
  "rays": [{}]
}"#;
        assert_eq!(call_lines(text), [5, 8, 10]);
        assert_eq!(call_lines(r#"{"calls": []}"#), Vec::<usize>::new());
        assert_eq!(call_lines(r#"{"calls":[{},{}]}"#), [1, 1]);
    }
}
