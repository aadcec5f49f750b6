//! Clearer scenario parse errors: an integer out of its type's range says the
//! range ("expected u32" becomes "expected an integer from 0 to 4294967295"),
//! and a JSON error names the key it happened at (serde_json gives only a
//! line and column; TOML errors already quote the offending line).

/// The integer types of the scenario format and their ranges.
const RANGES: [(&str, &str); 4] = [
    (
        "expected u32",
        "expected an integer from 0 to 4294967295 (u32)",
    ),
    (
        "expected u64",
        "expected an integer from 0 to 18446744073709551615 (u64)",
    ),
    (
        "expected usize",
        "expected an integer from 0 to 18446744073709551615 (usize)",
    ),
    (
        "expected i64",
        "expected an integer from -9223372036854775808 to 9223372036854775807 (i64)",
    ),
];

/// `message` with integer types spelled out as ranges.
pub(crate) fn with_ranges(message: &str) -> String {
    RANGES
        .iter()
        .fold(message.to_owned(), |m, (from, to)| m.replace(from, to))
}

/// A TOML error on `text` as a message naming the key of an out-of-range
/// integer. Inside the tagged `controller` table the parsers point at the
/// table, not the key, so the key is found by the integer's value.
pub(crate) fn toml_message(text: &str, error: &toml::de::Error) -> String {
    let raw = error.to_string();
    match key_of_integer(text, &raw) {
        Some(key) => format!("at key \"{key}\": {}", with_ranges(&raw)),
        None => with_ranges(&raw),
    }
}

/// The key holding the integer an "invalid value: integer `N`" error is about.
fn key_of_integer<'a>(text: &'a str, message: &str) -> Option<&'a str> {
    message
        .split_once("integer `")
        .and_then(|(_, rest)| rest.split_once('`'))
        .and_then(|(literal, _)| key_with_value(text, literal))
}

/// The first `key = literal` (TOML) or `"key": literal` (JSON) whose value
/// is exactly `literal`.
fn key_with_value<'a>(text: &'a str, literal: &str) -> Option<&'a str> {
    text.split(['\n', ',', '{']).find_map(|item| {
        let (key, value) = item.split_once(['=', ':'])?;
        let value = value.split('#').next().unwrap_or_default();
        let value = value.trim().trim_end_matches('}').trim();
        let key = key.trim().trim_matches('"');
        let plain = value.replace('_', "");
        (plain == literal && !key.is_empty() && !key.contains(char::is_whitespace)).then_some(key)
    })
}

/// A serde_json error on `text` as a message naming the key it is at.
pub(crate) fn json_message(text: &str, error: &serde_json::Error) -> String {
    let raw = error.to_string();
    let message = with_ranges(&raw);
    let key = key_of_integer(text, &raw).or_else(|| key_before(text, error.line(), error.column()));
    match key {
        Some(key) => format!("at key \"{key}\": {message}"),
        None => message,
    }
}

/// The last `"key":` before 1-based `line` and `column` of `text`.
fn key_before(text: &str, line: usize, column: usize) -> Option<&str> {
    if line == 0 {
        return None;
    }
    let line_start: usize = text
        .split_inclusive('\n')
        .take(line - 1)
        .map(str::len)
        .sum();
    let mut end = (line_start + column).min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let head = &text[..end];
    let colon = head.rfind(':')?;
    let before = head[..colon].trim_end();
    let quoted = before.strip_suffix('"')?;
    let open = quoted.rfind('"')?;
    let key = &quoted[open + 1..];
    (!key.is_empty() && key.len() <= 64).then_some(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_the_key_and_the_range() {
        let text = "{\n  \"controller\": {\"type\": \"script\", \"repeat\": -3}\n}";
        let error = serde_json::from_str::<std::collections::BTreeMap<String, serde_json::Value>>(
            "{\"a\": }",
        )
        .unwrap_err();
        assert!(json_message("{\"a\": }", &error).contains("at key \"a\""));
        assert_eq!(key_before(text, 2, 48), Some("repeat"));
        assert!(
            with_ranges("invalid value: integer `-3`, expected u32").contains("0 to 4294967295")
        );
    }
}
