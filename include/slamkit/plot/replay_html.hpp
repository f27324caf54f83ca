#pragma once
// The replay page: one self-contained HTML file (inline script and style, no network, no external
// files) that plays back a recording of a run (pipeline/replay.hpp's JSON, replay.json in a run
// folder). The page's template, style and script are src/plot/replay/replay.{html,css,js}, embedded
// at build time.
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace slamkit::plot {

/// The page for `recording`.
std::string replay_html(const nlohmann::json& recording);

/// Writes replay_html(recording) to `path`. Throws InputError if it cannot.
void write_replay_html(const std::string& path, const nlohmann::json& recording);

}  // namespace slamkit::plot
