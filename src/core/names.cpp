#include "slamkit/core/names.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstddef>

namespace slamkit {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// Optimal string alignment distance: Levenshtein's with a swap of neighbours as one edit, the
/// commonest typing slip ("rnu" for "run").
std::size_t edit_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::size_t> d((n + 1) * (m + 1));
  const auto at = [&](std::size_t i, std::size_t j) -> std::size_t& { return d[i * (m + 1) + j]; };
  for (std::size_t i = 0; i <= n; ++i) at(i, 0) = i;
  for (std::size_t j = 0; j <= m; ++j) at(0, j) = j;
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j) {
      at(i, j) = std::min({at(i - 1, j) + 1, at(i, j - 1) + 1, at(i - 1, j - 1) + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) at(i, j) = std::min(at(i, j), at(i - 2, j - 2) + 1);
    }
  return at(n, m);
}

}  // namespace

std::vector<std::string> similar_names(std::string_view given, const std::vector<std::string>& names) {
  const std::string typed = lower(given);
  // Short names are close to each other ("ekf", "ukf"), so the slack grows with the length.
  const std::size_t allowed = typed.size() <= 4 ? 1 : typed.size() <= 8 ? 2 : 3;
  std::size_t best = allowed;
  std::vector<std::string> nearest, extended;
  for (const std::string& name : names) {
    const std::string candidate = lower(name);
    if (typed.size() >= 3 && candidate.starts_with(typed) && candidate != typed) extended.push_back(name);
    const std::size_t distance = edit_distance(typed, candidate);
    if (distance > best) continue;
    if (distance < best) nearest.clear();
    best = distance;
    nearest.push_back(name);
  }
  return nearest.empty() ? extended : nearest;
}

std::string did_you_mean(std::string_view given, const std::vector<std::string>& names) {
  const std::vector<std::string> similar = similar_names(given, names);
  if (similar.empty()) return "";
  std::string list;
  for (std::size_t i = 0; i < similar.size(); ++i)
    list += fmt::format("{}'{}'", i == 0 ? "" : i + 1 == similar.size() ? " or " : ", ", similar[i]);
  return fmt::format(" (did you mean {}?)", list);
}

std::string unknown_name_message(std::string_view what, std::string_view given, const std::vector<std::string>& names) {
  return fmt::format("unknown {} '{}'{}; expected one of: {}", what, given, did_you_mean(given, names),
                     fmt::join(names, ", "));
}

}  // namespace slamkit
