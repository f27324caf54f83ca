#include "slamkit/plot/replay_html.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <string_view>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit_replay_assets.hpp"

namespace slamkit::plot {

namespace {

void replace(std::string& text, std::string_view placeholder, std::string_view content) {
  const std::size_t at = text.find(placeholder);
  if (at != std::string::npos) text.replace(at, placeholder.size(), content);
}

}  // namespace

std::string replay_html(const nlohmann::json& recording) {
  // Inside a <script> element the text "</" could end it early; "<\/" is the same JSON string.
  std::string json;
  for (const char c : recording.dump()) {
    if (c == '/' && !json.empty() && json.back() == '<') json += '\\';
    json += c;
  }
  std::string page = replay_assets::kHtml;
  // The data goes in last, so that text in it cannot be taken for a placeholder.
  replace(page, "@STYLE@", replay_assets::kCss);
  replace(page, "@SCRIPT@", replay_assets::kJs);
  replace(page, "@DATA@", json);
  return page;
}

void write_replay_html(const std::string& path, const nlohmann::json& recording) {
  write_file_atomically(path, replay_html(recording));
}

}  // namespace slamkit::plot
