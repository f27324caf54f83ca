// Tables from a report: templates filled from the runs of each filter and dataset entry, checked when
// read, and spliced into a Markdown document between their markers without touching the rest.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/campaign/report.hpp"
#include "slamkit/campaign/tables.hpp"
#include "slamkit/core/error.hpp"
#include "test_data.hpp"

namespace slamkit::campaign {
namespace {

using nlohmann::json;

/// Two filters on two datasets, two runs each (ATE, loop closed, spurious landmarks), except ekf on
/// "b", which has one run that diverged and measured no ATE.
Report two_by_two() {
  Report report;
  const auto add = [&](const std::string& filter, const std::string& dataset, std::vector<json> metrics) {
    ReportConfiguration c;
    c.label = filter + " | " + dataset;
    c.filter_entry = filter;
    c.dataset_entry = dataset;
    for (json& m : metrics) {
      c.runs.push_back(report.runs.size());
      ReportRun run;
      run.metrics = std::move(m);
      report.runs.push_back(std::move(run));
    }
    report.configurations.push_back(std::move(c));
  };
  add("ekf", "a",
      {{{"ate_rmse_m", 0.1}, {"loop_closed", true}, {"spurious_landmarks", 0}},
       {{"ate_rmse_m", 0.3}, {"loop_closed", false}, {"spurious_landmarks", 2}}});
  add("fej", "a",
      {{{"ate_rmse_m", 0.2}, {"loop_closed", true}, {"spurious_landmarks", 0}},
       {{"ate_rmse_m", 0.2}, {"loop_closed", true}, {"spurious_landmarks", 0}}});
  add("ekf", "b", {{{"loop_closed", false}, {"spurious_landmarks", 5}}});
  report.runs.back().diverged_at_s = 12.0;
  add("fej", "b",
      {{{"ate_rmse_m", 1.0}, {"loop_closed", true}, {"spurious_landmarks", 1}},
       {{"ate_rmse_m", 3.0}, {"loop_closed", true}, {"spurious_landmarks", 0}}});
  return report;
}

TableSpec table_of(const json& j) { return parse_report_tables(json::array({j}), "t.json").at(0); }

std::string error_of(const json& table) {
  try {
    table_of(table);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ReportTables, CellsAreTheTemplatesOverTheirRuns) {
  const TableSpec table = table_of(
      {{"name", "t"}, {"cell", "{loop_closed.yes}/{n} / {spurious_landmarks.zeros}/{n}, {ate_rmse_m.mean:.2f} m"}});
  EXPECT_EQ(render_table(two_by_two(), table),
            "| filter | a | b |\n"
            "|---|---|---|\n"
            "| ekf | 1/2 / 1/2, 0.20 m | 0/1 / 0/1, n/a m |\n"
            "| fej | 2/2 / 2/2, 0.20 m | 2/2 / 1/2, 2.00 m |\n");
}

TEST(ReportTables, EveryStatisticAndCount) {
  const Report report = two_by_two();
  const auto cell = [&](const std::string& text, const char* rows_are = "filter") {
    const std::string t = render_table(
        report, table_of({{"name", "t"}, {"rows_are", rows_are}, {"cell", text}, {"rows", {"fej"}}, {"columns", {"b"}}}));
    return t.substr(t.rfind("| fej | ") + 8, t.size() - t.rfind("| fej | ") - 8 - 3);
  };
  EXPECT_EQ(cell("{ate_rmse_m.median} {ate_rmse_m.min} {ate_rmse_m.max} {ate_rmse_m.sum} {ate_rmse_m.n}"), "2 1 3 4 2");
  EXPECT_EQ(cell("{loop_closed.yes} {loop_closed.no} {loop_closed.n} {spurious_landmarks.zeros}"), "2 0 2 1");
  // The 95% interval of the mean of {1, 3}: 2 -+ t(0.975, 1) * 1 = 2 -+ 12.7062.
  EXPECT_EQ(cell("[{ate_rmse_m.ci_low:.4f}, {ate_rmse_m.ci_high:.4f}]"), "[-10.7062, 14.7062]");
  EXPECT_EQ(cell("{ate_rmse_m.mean:.0%} {{braces}}"), "200% {braces}");
  const std::string diverged = render_table(
      report, table_of({{"name", "t"}, {"cell", "{diverged}/{n}, {partial} partial"}, {"rows", {"ekf"}}}));
  EXPECT_NE(diverged.find("| ekf | 0/2, 0 partial | 1/1, 0 partial |"), std::string::npos) << diverged;
}

TEST(ReportTables, RowsAndColumnsCanBeChosenLabelledAndGivenTheirOwnCell) {
  const TableSpec table = table_of({{"name", "t"},
                                    {"rows_are", "dataset"},
                                    {"corner", "world"},
                                    {"cell", "{ate_rmse_m.mean:.1f}"},
                                    {"rows", {"b"}},
                                    {"columns",
                                     {{{"key", "fej"}, {"label", "FEJ | EKF"}},
                                      {{"key", "fej"}, {"label", "loops"}, {"cell", "{loop_closed.yes}"}}}}});
  EXPECT_EQ(render_table(two_by_two(), table), "| world | FEJ \\| EKF | loops |\n|---|---|---|\n| b | 2.0 | 2 |\n");
  try {
    render_table(two_by_two(), table_of({{"name", "t"}, {"cell", "{n}"}, {"rows", {"ekff"}}}));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "t.json: tables[0].rows[0]: no run of the filter entry 'ekff' (did you mean 'ekf'?)");
  }
}

TEST(ReportTables, AMalformedTableIsAnErrorNamingTheKey) {
  EXPECT_EQ(error_of({{"name", "t"}, {"cell", "{ate_rmse_m.avg}"}}),
            "t.json: tables[0].cell: '{ate_rmse_m.avg}': unknown statistic 'avg'; expected one of: mean, median, min, "
            "max, ci_low, ci_high, n, sum, zeros, yes, no");
  EXPECT_EQ(error_of({{"name", "t"}, {"cell", "{ate_rmse_m.mean:.2q}"}}).substr(0, 71),
            "t.json: tables[0].cell: '{ate_rmse_m.mean:.2q}': the format '.2q' does ");
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{loop_closed.yes:.0%}"}}).find("a count is not a share"),
            std::string::npos);
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{ate_rmse_m.mean"}}).find("a '{' without its '}'"), std::string::npos);
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{runs}"}}).find("unknown count 'runs'"), std::string::npos);
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{n}"}, {"colums", {"a"}}}).find("unknown key 'colums' (did you mean 'columns'?)"),
            std::string::npos);
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{n}"}, {"rows_are", "filters"}}).find("tables[0].rows_are"),
            std::string::npos);
  EXPECT_NE(error_of({{"name", "t"}, {"cell", "{n}"}, {"rows", json::array()}}).find("tables[0].rows: expected a non-empty"),
            std::string::npos);
  EXPECT_NE(error_of({{"name", "a -- b"}, {"cell", "{n}"}}).find("cannot stand in a Markdown comment"), std::string::npos);
  EXPECT_NE(error_of({{"cell", "{n}"}}).find("tables[0]: expected 'name'"), std::string::npos);
}

TEST(ReportTables, ATableIsSplicedBetweenItsMarkersAndNothingElseMoves) {
  const std::string document =
      "# Results\n\nbefore\n<!-- slamkit report table: t -->\n| old |\n<!-- end slamkit report table -->\nafter\n"
      "<!-- slamkit report table: u -->\n<!-- end slamkit report table -->\n";
  const std::string spliced = splice_tables(document, {{"t", "| new |\n"}, {"u", "| other |\n"}}, "doc.md");
  EXPECT_EQ(spliced,
            "# Results\n\nbefore\n<!-- slamkit report table: t -->\n\n| new |\n\n<!-- end slamkit report table -->\n"
            "after\n<!-- slamkit report table: u -->\n\n| other |\n\n<!-- end slamkit report table -->\n");
  // Splicing again gives the same document: a regenerated README changes only where numbers do.
  EXPECT_EQ(splice_tables(spliced, {{"t", "| new |\n"}, {"u", "| other |\n"}}, "doc.md"), spliced);

  const auto error = [&](const std::string& doc, const std::string& name) {
    try {
      splice_tables(doc, {{name, "| x |\n"}}, "doc.md");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error(document, "v"), "doc.md: no marker '<!-- slamkit report table: v -->' for the table 'v'");
  EXPECT_NE(error("<!-- slamkit report table: t -->\n| a |\n", "t").find("has no '<!-- end slamkit report table -->'"),
            std::string::npos);
  EXPECT_NE(error("<!-- slamkit report table: t -->\n<!-- slamkit report table: u -->\n<!-- end slamkit report table "
                  "-->\n",
                  "t")
                .find("has no '<!-- end"),
            std::string::npos);
  EXPECT_NE(error(document + document, "t").find("is there twice"), std::string::npos);
}

TEST(ReportTables, ADocumentIsSplicedBeforeAnythingIsWrittenAndKeepsItsLineEndingsAndPermissions) {
  test_data::ScratchDir dir;
  const std::string path = dir.file("doc.md");
  const std::string text = "<!-- slamkit report table: t -->\r\n| a |\r\n<!-- end slamkit report table -->\r\n";
  test_data::write_text(path, text);
  std::filesystem::permissions(path, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  EXPECT_THROW(spliced_document(path, {{"t", "| b |\n"}, {"missing", "| c |\n"}}), InputError);
  EXPECT_EQ(test_data::read_text(path), text);
  write_document(path, spliced_document(path, {{"t", "| b |\n|---|\n"}}));
  EXPECT_EQ(test_data::read_text(path),
            "<!-- slamkit report table: t -->\r\n\r\n| b |\r\n|---|\r\n\r\n<!-- end slamkit report table -->\r\n");
  EXPECT_EQ(std::filesystem::status(path).permissions(),
            std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  // Through a link, the file it names is rewritten and the link stays a link.
  const std::string link = dir.file("link.md");
  std::filesystem::create_symlink(path, link);
  write_document(link, "<!-- slamkit report table: t -->\n<!-- end slamkit report table -->\n");
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(test_data::read_text(path), "<!-- slamkit report table: t -->\n<!-- end slamkit report table -->\n");
}

}  // namespace
}  // namespace slamkit::campaign
