#pragma once
// What to say when a name the user typed (a filter, a variant, a scenario, a dataset kind, a settings
// key, a subcommand or an option) is not one slamkit knows: the accepted names, and the ones it most
// likely meant when it looks like a misspelling of them.
#include <string>
#include <string_view>
#include <vector>

namespace slamkit {

/// The names `given` is probably a misspelling of: those at the smallest edit distance from it
/// (insertions, deletions, substitutions and swaps of neighbouring characters, case ignored) when
/// that distance is small for its length (1 up to 4 characters, 2 up to 8, else 3), in the order of
/// `names`; failing that, the names it begins (at least 3 characters: "fast" for fastslam1 and
/// fastslam2). Empty when nothing is close.
std::vector<std::string> similar_names(std::string_view given, const std::vector<std::string>& names);

/// " (did you mean 'a'?)" or " (did you mean 'a' or 'b'?)" for similar_names, or "" when there are none.
std::string did_you_mean(std::string_view given, const std::vector<std::string>& names);

/// "unknown WHAT 'GIVEN' (did you mean 'a'?); expected one of: a, b, c".
std::string unknown_name_message(std::string_view what, std::string_view given, const std::vector<std::string>& names);

}  // namespace slamkit
