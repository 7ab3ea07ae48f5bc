//! Reports as data: a [`Document`] of lines and [`Table`]s, built once by each report, and
//! rendered as plain text (aligned columns, what a terminal shows) or as Markdown (`--markdown`,
//! what BENCHMARKS.md and RELIABILITY.md quote), so the documents carry what a command printed
//! rather than figures typed by hand, and the two forms cannot say different things.

/// Which side a column's cells lean to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Text.
    Left,
    /// Numbers.
    Right,
}

/// A table being built.
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

    /// Whether it has no rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    fn cells(&self, row: &[String]) -> Vec<String> {
        (0..self.columns.len())
            .map(|i| row.get(i).cloned().unwrap_or_default())
            .collect()
    }

    /// The table as Markdown, one line per row.
    pub fn markdown(&self) -> String {
        let line = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
        let mut out = line(self.columns.iter().map(|(name, _)| name.clone()).collect());
        let rule: Vec<&str> = self
            .columns
            .iter()
            .map(|(_, align)| match align {
                Align::Left => "---",
                Align::Right => "---:",
            })
            .collect();
        out += &format!("|{}|\n", rule.join("|"));
        for row in &self.rows {
            out += &line(self.cells(row));
        }
        out
    }

    /// The table as plain text: each column as wide as its widest cell, numbers to the right.
    pub fn text(&self) -> String {
        let rows: Vec<Vec<String>> = self.rows.iter().map(|r| self.cells(r)).collect();
        let width = |i: usize| {
            rows.iter()
                .map(|r| r[i].chars().count())
                .chain([self.columns[i].0.chars().count()])
                .max()
                .unwrap_or(0)
        };
        let widths: Vec<usize> = (0..self.columns.len()).map(width).collect();
        let line = |cells: &[String]| {
            let padded: Vec<String> = cells
                .iter()
                .zip(&self.columns)
                .zip(&widths)
                .map(|((cell, (_, align)), &w)| match align {
                    Align::Left => format!("{cell:<w$}"),
                    Align::Right => format!("{cell:>w$}"),
                })
                .collect();
            format!("{}\n", padded.join("  ").trim_end())
        };
        let header: Vec<String> = self.columns.iter().map(|(n, _)| n.clone()).collect();
        let mut out = line(&header);
        let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
        out += &line(&rule);
        for row in &rows {
            out += &line(row);
        }
        out
    }
}

/// One piece of a report.
#[derive(Debug, Clone)]
enum Block {
    /// A line of text (empty: a blank line).
    Line(String),
    Table(Table),
}

/// A report: lines and tables, in order, rendered whole in either form.
#[derive(Debug, Clone, Default)]
pub struct Document {
    blocks: Vec<Block>,
}

impl Document {
    /// An empty report.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a line of text (several, if it holds newlines; empty: a blank line).
    pub fn line(&mut self, text: impl Into<String>) {
        let text = text.into();
        if text.is_empty() {
            self.blocks.push(Block::Line(String::new()));
        }
        for line in text.lines() {
            self.blocks.push(Block::Line(line.to_owned()));
        }
    }

    /// Adds a table.
    pub fn table(&mut self, table: Table) {
        self.blocks.push(Block::Table(table));
    }

    /// Adds everything of `other`.
    pub fn append(&mut self, other: Document) {
        self.blocks.extend(other.blocks);
    }

    /// The report as plain text.
    pub fn text(&self) -> String {
        let mut out = String::new();
        for block in &self.blocks {
            match block {
                Block::Line(line) => {
                    out += line;
                    out.push('\n');
                }
                Block::Table(table) => out += &table.text(),
            }
        }
        out
    }

    /// The report as Markdown: tables set apart by blank lines, as Markdown needs them.
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        for block in &self.blocks {
            match block {
                Block::Line(line) => {
                    out += line;
                    out.push('\n');
                }
                Block::Table(table) => {
                    if !out.is_empty() && !out.ends_with("\n\n") {
                        out.push('\n');
                    }
                    out += &table.markdown();
                    out.push('\n');
                }
            }
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

    fn table() -> Table {
        let mut table = Table::new(&[("name", Align::Left), ("n", Align::Right)]);
        table.row(vec!["a".into(), grouped(1_504_971)]);
        table.row(vec!["bb".into()]);
        table
    }

    #[test]
    fn renders_header_alignment_and_rows() {
        assert_eq!(
            table().markdown(),
            "| name | n |\n|---|---:|\n| a | 1 504 971 |\n| bb |  |\n"
        );
        assert_eq!(
            table().text(),
            "name          n\n----  ---------\na     1 504 971\nbb\n"
        );
    }

    #[test]
    fn one_document_two_forms() {
        let mut doc = Document::new();
        doc.line("title");
        doc.table(table());
        doc.line("after");
        assert_eq!(doc.text(), format!("title\n{}after\n", table().text()));
        assert_eq!(
            doc.markdown(),
            format!("title\n\n{}\nafter\n", table().markdown())
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
