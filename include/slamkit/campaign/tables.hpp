#pragma once
// Tables for a document, made from a report: rows of filters (or datasets), columns of datasets (or
// filters), and in each cell a template over the runs of that filter on that dataset, e.g.
//   "{loop_closed.yes}/{n} / {spurious_landmarks.zeros}/{n}"   ->  "19/20 / 18/20"
//   "{ate_rmse_m.mean:.3f} m"                                  ->  "0.208 m"
//   "{nees_pose_in_95_fraction.mean:.0%}"                      ->  "93%"
// A table is written as Markdown, and can replace the table of the same name in a Markdown file
// between the markers
//   <!-- slamkit report table: NAME -->
//   <!-- end slamkit report table -->
// so a README's tables are regenerated from a campaign rather than copied by hand. docs/campaigns.md
// documents the spec (the "tables" key of a campaign, or of a file given to report --tables).
#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "slamkit/campaign/report.hpp"

namespace slamkit::campaign {

/// A row or column: the filter or dataset entry it takes its runs from (a campaign's entry name with
/// its varied values, as in its configurations "ekf | sparse"), its heading, and its cell template
/// where it differs from the table's (a row's wins over a column's).
struct TableLine {
  std::string key;
  std::string label;
  std::string cell;
};

struct TableSpec {
  std::string source;      // the file it was read from, and
  std::size_t index = 0;   // its place in that file's "tables", for errors
  std::string name;
  /// "filter": rows are filter entries and columns dataset entries; "dataset": the other way round.
  std::string rows_are = "filter";
  std::string corner;  // the heading above the row labels
  /// Empty: every entry the report has, in the order of its first run (runs are in folder order).
  std::vector<TableLine> rows, columns;
  std::string cell;
};

/// The "tables" value of a spec: a list of {"name", "rows_are": "filter"|"dataset", "corner", "cell",
/// "rows": [...], "columns": [...]}, each row or column an entry's key or {"key", "label", "cell"}.
/// Templates are checked here. Throws InputError naming `source` and the key
/// ("tables[0].cell: unknown statistic 'avg' ...").
std::vector<TableSpec> parse_report_tables(const nlohmann::json& tables, const std::string& source);

/// The "tables" of a JSON file (a campaign spec, or a file holding only "tables"); InputError if it
/// has none.
std::vector<TableSpec> read_report_tables(const std::string& path);

/// The table as Markdown (a heading row, a rule, a row per row entry), each cell its template filled
/// in from the runs of its row and column entries; a cell without runs is empty. InputError naming
/// the table's file and key if a listed row or column has no run in the report.
std::string render_table(const Report& report, const TableSpec& table);

/// `markdown` with the text between each table's markers replaced by the table (in the document's
/// line endings); `source` names the document in errors. Throws InputError if a table's markers are
/// missing, repeated or unclosed.
std::string splice_tables(const std::string& markdown, const std::vector<std::pair<std::string, std::string>>& tables,
                          const std::string& source);

/// Writes the tables into `dir` (an existing folder) as tables.md, each under a heading of its
/// name, whole or not at all; returns the file's path.
std::string write_tables(const std::vector<std::pair<std::string, std::string>>& rendered, const std::string& dir);

/// The Markdown file `path` with its tables replaced (splice_tables); InputError if it cannot be
/// read or lacks a table's markers. Nothing is written: a caller splices before it writes anything.
std::string spliced_document(const std::string& path, const std::vector<std::pair<std::string, std::string>>& rendered);

/// Replaces the document `path` (through a link, the file it names) by `text`, whole or not at all,
/// keeping its permissions.
void write_document(const std::string& path, const std::string& text);

}  // namespace slamkit::campaign
