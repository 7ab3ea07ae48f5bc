//! Markdown tables, as BENCHMARKS.md and RELIABILITY.md quote them: `--markdown` on `seam
//! ping`, `ops`, `run` and `chaos` prints the measured rows this way, so the documents carry
//! what a command printed rather than figures typed by hand.

/// Which side a column's cells lean to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Text.
    Left,
    /// Numbers.
    Right,
}

/// A Markdown table being built.
#[derive(Debug, Clone)]
pub struct Table {
    columns: Vec<(String, Align)>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these columns.
    pub fn new(columns: &[(&str, Align)]) -> Self {
        Self {
            columns: columns
                .iter()
                .map(|&(name, align)| (name.to_owned(), align))
                .collect(),
            rows: Vec::new(),
        }
    }

    /// Adds a row (as many cells as columns; missing cells stay empty).
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    /// The table as Markdown, one line per row.
    pub fn render(&self) -> String {
        let line = |cells: &mut dyn Iterator<Item = String>| {
            let cells: Vec<String> = cells.collect();
            format!("| {} |\n", cells.join(" | "))
        };
        let mut out = line(&mut self.columns.iter().map(|(name, _)| name.clone()));
        out += &format!(
            "|{}|\n",
            self.columns
                .iter()
                .map(|(_, align)| match align {
                    Align::Left => "---",
                    Align::Right => "---:",
                })
                .collect::<Vec<_>>()
                .join("|")
        );
        for row in &self.rows {
            let mut cells =
                (0..self.columns.len()).map(|i| row.get(i).cloned().unwrap_or_default());
            out += &line(&mut cells);
        }
        out
    }
}

/// `n` with its thousands grouped by spaces (`1 504 971`), as the documents write them.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_header_alignment_and_rows() {
        let mut table = Table::new(&[("name", Align::Left), ("n", Align::Right)]);
        table.row(vec!["a".into(), grouped(1_504_971)]);
        table.row(vec!["b".into()]);
        assert_eq!(
            table.render(),
            "| name | n |\n|---|---:|\n| a | 1 504 971 |\n| b |  |\n"
        );
    }

    #[test]
    fn groups_thousands() {
        assert_eq!(grouped(0), "0");
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(1000), "1 000");
        assert_eq!(grouped(123_456_789), "123 456 789");
    }
}
