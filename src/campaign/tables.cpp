#include "slamkit/campaign/tables.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>
#include <variant>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/names.hpp"

namespace slamkit::campaign {
namespace {

using nlohmann::json;

constexpr std::string_view kBeginMarker = "<!-- slamkit report table: ";
constexpr std::string_view kEndMarker = "<!-- end slamkit report table -->";

// What a placeholder can ask of a metric over a cell's runs. Counts are whole numbers; the rest are
// MetricSummary's figures.
const std::vector<std::string> kStatistics = {"mean", "median", "min",  "max", "ci_low", "ci_high",
                                              "n",    "sum",    "zeros", "yes", "no"};
// Placeholders without a metric: the cell's runs, and those of them that stopped early.
const std::vector<std::string> kCellCounts = {"n", "partial", "diverged"};

bool is_count(const std::string& statistic) {
  return statistic == "n" || statistic == "zeros" || statistic == "yes" || statistic == "no" ||
         statistic == "partial" || statistic == "diverged";
}

/// "{metric.statistic:spec}" or "{n}"; the spec is fmt's, or ends in '%' as Python's does (the value
/// times 100, fixed, then a percent sign).
struct Placeholder {
  std::string metric;     // empty for a cell count
  std::string statistic;  // the cell count's name when metric is empty
  std::string spec;       // fmt's, without the '%'
  bool percent = false;
};

using Piece = std::variant<std::string, Placeholder>;

std::string format_value(const Placeholder& p, double value) {
  if (is_count(p.statistic)) {
    const auto count = static_cast<long long>(std::llround(value));
    return fmt::format(fmt::runtime("{:" + p.spec + "}"), count);
  }
  if (p.percent) return fmt::format(fmt::runtime("{:" + p.spec + "f}%"), 100.0 * value);
  return fmt::format(fmt::runtime("{:" + p.spec + "}"), value);
}

/// The template's pieces; std::invalid_argument saying what is wrong with it.
std::vector<Piece> parse_template(const std::string& text) {
  std::vector<Piece> pieces;
  std::string literal;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if ((c == '{' || c == '}') && i + 1 < text.size() && text[i + 1] == c) {
      literal += c;
      ++i;
      continue;
    }
    if (c == '}') throw std::invalid_argument(fmt::format("a '}}' without its '{{' at character {}", i + 1));
    if (c != '{') {
      literal += c;
      continue;
    }
    const std::size_t close = text.find('}', i);
    if (close == std::string::npos)
      throw std::invalid_argument(fmt::format("a '{{' without its '}}' at character {}", i + 1));
    const std::string inside = text.substr(i + 1, close - i - 1);
    const std::size_t colon = inside.find(':');
    const std::string name = inside.substr(0, colon);
    Placeholder p;
    if (colon != std::string::npos) p.spec = inside.substr(colon + 1);
    if (!p.spec.empty() && p.spec.back() == '%') {
      p.spec.pop_back();
      p.percent = true;
    }
    if (const std::size_t dot = name.rfind('.'); dot == std::string::npos) {
      if (std::find(kCellCounts.begin(), kCellCounts.end(), name) == kCellCounts.end())
        throw std::invalid_argument(fmt::format("'{{{}}}': expected {{METRIC.STATISTIC}} or a count of the cell's runs; {}",
                                                inside, unknown_name_message("count", name, kCellCounts)));
      p.statistic = name;
    } else {
      p.metric = name.substr(0, dot);
      p.statistic = name.substr(dot + 1);
      if (p.metric.empty()) throw std::invalid_argument(fmt::format("'{{{}}}': no metric before the '.'", inside));
      if (std::find(kStatistics.begin(), kStatistics.end(), p.statistic) == kStatistics.end())
        throw std::invalid_argument(
            fmt::format("'{{{}}}': {}", inside, unknown_name_message("statistic", p.statistic, kStatistics)));
    }
    if (p.percent && is_count(p.statistic))
      throw std::invalid_argument(fmt::format("'{{{}}}': a count is not a share; '%' is for a mean or median", inside));
    try {
      format_value(p, 0.5);
    } catch (const fmt::format_error& e) {
      throw std::invalid_argument(fmt::format("'{{{}}}': the format '{}' does not apply: {}", inside, p.spec, e.what()));
    }
    if (!literal.empty()) pieces.emplace_back(std::move(literal));
    literal.clear();
    pieces.emplace_back(std::move(p));
    i = close;
  }
  if (!literal.empty()) pieces.emplace_back(std::move(literal));
  return pieces;
}

/// A placeholder's value over the runs; none where no run measured the metric.
std::optional<double> statistic_of(const Placeholder& p, const Report& report, const std::vector<std::size_t>& runs) {
  if (p.metric.empty()) {
    std::size_t count = 0;
    for (const std::size_t r : runs)
      count += p.statistic == "n" ||
               (p.statistic == "partial" ? report.runs[r].partial : report.runs[r].diverged_at_s.has_value());
    return static_cast<double>(count);
  }
  const MetricSummary s = summarize_metric(p.metric, report, runs);
  if (p.statistic == "yes" || p.statistic == "no") {
    if (s.yes_no == 0) return std::nullopt;
    return static_cast<double>(p.statistic == "yes" ? s.yes : s.yes_no - s.yes);
  }
  if (p.statistic == "n" && s.n == 0 && s.yes_no > 0) return static_cast<double>(s.yes_no);
  if (s.n == 0) return std::nullopt;
  if (p.statistic == "n") return static_cast<double>(s.n);
  if (p.statistic == "mean") return s.mean;
  if (p.statistic == "median") return s.median;
  if (p.statistic == "min") return s.min;
  if (p.statistic == "max") return s.max;
  if (p.statistic == "ci_low" || p.statistic == "ci_high") {
    if (!s.ci95) return std::nullopt;
    return p.statistic == "ci_low" ? s.ci95->lo : s.ci95->hi;
  }
  return p.statistic == "sum" ? s.sum : static_cast<double>(s.zeros);
}

std::string fill(const std::vector<Piece>& pieces, const Report& report, const std::vector<std::size_t>& runs) {
  std::string out;
  for (const Piece& piece : pieces) {
    if (const auto* text = std::get_if<std::string>(&piece)) {
      out += *text;
      continue;
    }
    const auto& p = std::get<Placeholder>(piece);
    const std::optional<double> value = statistic_of(p, report, runs);
    out += value ? format_value(p, *value) : "n/a";
  }
  return out;
}

/// A Markdown cell: its pipes escaped, its line breaks spaces.
std::string cell_text(std::string text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out;
}

void fail(const std::string& source, const std::string& key, const std::string& what) {
  throw InputError(source, 0, fmt::format("{}: {}", key, what));
}

std::string string_in(const json& object, const char* key, const std::string& source, const std::string& where,
                      bool required) {
  if (!object.contains(key)) {
    if (required) fail(source, where, fmt::format("expected '{}'", key));
    return "";
  }
  if (!object[key].is_string()) fail(source, where + "." + key, fmt::format("expected a string, found {}", object[key].dump()));
  return object[key].get<std::string>();
}

void check_template(const std::string& text, const std::string& source, const std::string& where) {
  try {
    parse_template(text);
  } catch (const std::invalid_argument& e) {
    fail(source, where, e.what());
  }
}

std::vector<TableLine> parse_lines(const json& table, const char* key, const std::string& source,
                                   const std::string& where) {
  std::vector<TableLine> lines;
  if (!table.contains(key)) return lines;
  const std::string here = where + "." + key;
  if (!table[key].is_array() || table[key].empty())
    fail(source, here, fmt::format("expected a non-empty list of entries, found {}", table[key].dump()));
  for (std::size_t i = 0; i < table[key].size(); ++i) {
    const json& item = table[key][i];
    const std::string at = fmt::format("{}[{}]", here, i);
    TableLine line;
    if (item.is_string()) {
      line.key = line.label = item.get<std::string>();
    } else if (item.is_object()) {
      for (const auto& entry : item.items())
        if (entry.key() != "key" && entry.key() != "label" && entry.key() != "cell")
          fail(source, at, unknown_name_message("key", entry.key(), {"key", "label", "cell"}));
      line.key = string_in(item, "key", source, at, true);
      line.label = item.contains("label") ? string_in(item, "label", source, at, false) : line.key;
      line.cell = string_in(item, "cell", source, at, false);
      if (!line.cell.empty()) check_template(line.cell, source, at + ".cell");
    } else {
      fail(source, at, fmt::format("expected an entry's name or {{\"key\", \"label\", \"cell\"}}, found {}", item.dump()));
    }
    lines.push_back(std::move(line));
  }
  return lines;
}

/// The entries the report has on one side of the table, in the order of their first run.
std::vector<TableLine> entries_of(const Report& report, bool filters) {
  std::vector<TableLine> lines;
  for (const ReportConfiguration& c : report.configurations) {
    const std::string& key = filters ? c.filter_entry : c.dataset_entry;
    if (std::none_of(lines.begin(), lines.end(), [&](const TableLine& l) { return l.key == key; }))
      lines.push_back({key, key, ""});
  }
  return lines;
}

}  // namespace

std::vector<TableSpec> parse_report_tables(const json& tables, const std::string& source) {
  if (!tables.is_array()) fail(source, "tables", fmt::format("expected a list of tables, found {}", tables.dump()));
  std::vector<TableSpec> specs;
  for (std::size_t t = 0; t < tables.size(); ++t) {
    const json& table = tables[t];
    const std::string where = fmt::format("tables[{}]", t);
    const std::vector<std::string> keys = {"name", "rows_are", "corner", "cell", "rows", "columns"};
    if (!table.is_object()) fail(source, where, fmt::format("expected an object, found {}", table.dump()));
    for (const auto& entry : table.items())
      if (std::find(keys.begin(), keys.end(), entry.key()) == keys.end())
        fail(source, where, unknown_name_message("key", entry.key(), keys));
    TableSpec spec;
    spec.source = source;
    spec.index = t;
    spec.name = string_in(table, "name", source, where, true);
    if (spec.name.empty() || spec.name.find_first_of("\n>") != std::string::npos ||
        spec.name.find("--") != std::string::npos)
      fail(source, where + ".name", fmt::format("'{}' cannot stand in a Markdown comment", spec.name));
    if (std::any_of(specs.begin(), specs.end(), [&](const TableSpec& s) { return s.name == spec.name; }))
      fail(source, where + ".name", fmt::format("a second table named '{}'", spec.name));
    if (table.contains("rows_are")) {
      spec.rows_are = string_in(table, "rows_are", source, where, false);
      if (spec.rows_are != "filter" && spec.rows_are != "dataset")
        fail(source, where + ".rows_are", unknown_name_message("side", spec.rows_are, {"filter", "dataset"}));
    }
    spec.corner = table.contains("corner") ? string_in(table, "corner", source, where, false) : spec.rows_are;
    spec.cell = string_in(table, "cell", source, where, true);
    check_template(spec.cell, source, where + ".cell");
    spec.rows = parse_lines(table, "rows", source, where);
    spec.columns = parse_lines(table, "columns", source, where);
    specs.push_back(std::move(spec));
  }
  return specs;
}

std::vector<TableSpec> read_report_tables(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the tables' file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(path, 0, fmt::format("not JSON: {}", e.what()));
  }
  if (!j.is_object() || !j.contains("tables"))
    throw InputError(path, 0, "expected an object with 'tables' (a campaign spec or a file of tables)");
  return parse_report_tables(j["tables"], path);
}

std::string render_table(const Report& report, const TableSpec& table) {
  const bool filter_rows = table.rows_are == "filter";
  const std::vector<TableLine> rows = table.rows.empty() ? entries_of(report, filter_rows) : table.rows;
  const std::vector<TableLine> columns = table.columns.empty() ? entries_of(report, !filter_rows) : table.columns;
  for (const auto& [side, lines, filter] : {std::tuple{"rows", &rows, filter_rows},
                                             std::tuple{"columns", &columns, !filter_rows}}) {
    std::vector<std::string> keys;
    for (const TableLine& entry : entries_of(report, filter)) keys.push_back(entry.key);
    for (std::size_t i = 0; i < lines->size(); ++i)
      if (std::find(keys.begin(), keys.end(), (*lines)[i].key) == keys.end())
        throw InputError(table.source, 0,
                         fmt::format("tables[{}].{}[{}]: no run of the {} entry '{}'{}", table.index, side, i,
                                     filter ? "filter" : "dataset", (*lines)[i].key, did_you_mean((*lines)[i].key, keys)));
  }
  std::string out = "| " + cell_text(table.corner) + " |";
  for (const TableLine& column : columns) out += fmt::format(" {} |", cell_text(column.label));
  out += "\n|---|";
  for (std::size_t c = 0; c < columns.size(); ++c) out += "---|";
  out += '\n';
  std::map<std::string, std::vector<Piece>> templates;
  for (const TableLine& row : rows) {
    out += fmt::format("| {} |", cell_text(row.label));
    for (const TableLine& column : columns) {
      const std::string& filter_key = filter_rows ? row.key : column.key;
      const std::string& dataset_key = filter_rows ? column.key : row.key;
      std::vector<std::size_t> runs;
      for (const ReportConfiguration& c : report.configurations)
        if (c.filter_entry == filter_key && c.dataset_entry == dataset_key)
          runs.insert(runs.end(), c.runs.begin(), c.runs.end());
      const std::string& cell = !row.cell.empty() ? row.cell : !column.cell.empty() ? column.cell : table.cell;
      out += ' ';
      if (!runs.empty()) {
        auto [parsed, fresh] = templates.try_emplace(cell);
        if (fresh) parsed->second = parse_template(cell);
        out += cell_text(fill(parsed->second, report, runs));
      }
      out += " |";
    }
    out += '\n';
  }
  return out;
}

std::string splice_tables(const std::string& markdown, const std::vector<std::pair<std::string, std::string>>& tables,
                          const std::string& source) {
  std::string out = markdown;
  for (const auto& [name, text] : tables) {
    const std::string begin = fmt::format("{}{} -->", kBeginMarker, name);
    const std::size_t at = out.find(begin);
    if (at == std::string::npos)
      throw InputError(source, 0, fmt::format("no marker '{}' for the table '{}'", begin, name));
    if (out.find(begin, at + begin.size()) != std::string::npos)
      throw InputError(source, 0, fmt::format("the marker '{}' is there twice", begin));
    const std::size_t line_end = out.find('\n', at);
    const std::size_t from = line_end == std::string::npos ? out.size() : line_end + 1;
    const std::size_t end = out.find(kEndMarker, from);
    const std::size_t next_begin = out.find(kBeginMarker, from);
    if (end == std::string::npos || (next_begin != std::string::npos && next_begin < end))
      throw InputError(source, 0, fmt::format("the table '{}' has no '{}' after its marker", name, kEndMarker));
    // Blank lines around the table: a table touching an HTML comment is not a table to every renderer.
    std::string table = "\n" + text + "\n";
    if (from >= 2 && out.compare(from - 2, 2, "\r\n") == 0) {  // the document's line endings
      std::string crlf;
      for (const char c : table) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
      table = std::move(crlf);
    }
    out.replace(from, end - from, table);
  }
  return out;
}

std::string write_tables(const std::vector<std::pair<std::string, std::string>>& rendered, const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / "tables.md").string();
  std::string text;
  for (const auto& [name, table] : rendered) text += fmt::format("## {}\n\n{}\n", name, table);
  write_file_atomically(path, text);
  return path;
}

std::string spliced_document(const std::string& path, const std::vector<std::pair<std::string, std::string>>& rendered) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the document to put the tables in");
  std::stringstream text;
  text << in.rdbuf();
  return splice_tables(text.str(), rendered, path);
}

void write_document(const std::string& path, const std::string& text) {
  std::error_code error;
  // Through a link to the file it names, and with the file's permissions: a README kept elsewhere
  // or read-only to others stays so.
  const std::filesystem::path target = std::filesystem::canonical(path, error);
  if (error) throw InputError(path, 0, fmt::format("cannot find the document: {}", error.message()));
  const std::filesystem::perms permissions = std::filesystem::status(target, error).permissions();
  write_file_atomically(target.string(), text);
  if (!error) std::filesystem::permissions(target, permissions, error);
}

}  // namespace slamkit::campaign
