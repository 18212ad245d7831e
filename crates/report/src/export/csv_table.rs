//! Tables as CSV (RFC 4180, through the `csv` crate): every text field is
//! quoted where it must be, so an observer named "Smith, J." or a note with
//! a quote keeps its columns. One writer for every CSV lightbooth writes
//! from rows it built (analyses, thresholds, failure maps).

/// `header` and `rows` (each as long as the header) as CSV text, one line
/// per row ending in `\n`.
pub fn csv_table(header: &[&str], rows: impl IntoIterator<Item = Vec<String>>) -> Result<String, String> {
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    w.write_record(header).map_err(|e| e.to_string())?;
    for (i, row) in rows.into_iter().enumerate() {
        if row.len() != header.len() {
            return Err(format!(
                "CSV row {}: {} fields for {} columns",
                i + 1,
                row.len(),
                header.len()
            ));
        }
        w.write_record(&row).map_err(|e| e.to_string())?;
    }
    let bytes = w.into_inner().map_err(|e| e.to_string())?;
    String::from_utf8(bytes).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A comma, a quote and a line break in a field keep their columns,
    /// read back by the `csv` crate's reader.
    #[test]
    fn fields_with_commas_quotes_and_newlines_keep_their_columns() {
        let text = csv_table(
            &["observer", "note"],
            [vec!["Smith, J.".to_string(), "said \"no\"\nthen yes".to_string()]],
        )
        .unwrap();
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
        assert_eq!(rows.len(), 1);
        assert_eq!(&rows[0][0], "Smith, J.");
        assert_eq!(&rows[0][1], "said \"no\"\nthen yes");
        assert!(csv_table(&["a", "b"], [vec!["1".to_string()]]).is_err());
    }
}
