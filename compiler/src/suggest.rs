//! "Did you mean": the known name closest to a mistyped one, for the help of a diagnostic.

/// Levenshtein distance in characters (`strsim`).
pub fn edit_distance(a: &str, b: &str) -> usize {
    strsim::levenshtein(a, b)
}

/// The closest of `candidates` to `name`, if it is close enough to be a likely typo: at most two
/// edits, or one per four characters of a longer candidate. An exact match is no suggestion.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, c)| *d > 0 && *d <= 2.max(c.len() / 4))
        .min()
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn close_names_are_suggested_and_far_ones_are_not() {
        assert_eq!(did_you_mean("shadng", ["shading", "sampling"]), Some("shading"));
        assert_eq!(did_you_mean("shading", ["shading"]), None);
        assert_eq!(did_you_mean("xyz", ["shading"]), None);
        // A tie goes to the name first in alphabetical order.
        assert_eq!(did_you_mean("ab", ["ad", "ac"]), Some("ac"));
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
