#include "slamkit/io/dataset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <string_view>

#include "slamkit/error.hpp"
#include "slamkit/io/sim_log.hpp"

namespace slamkit {
namespace {

struct DatasetKind {
  std::string_view name;
  Dataset (*read)(const std::string& path);
};

// Every reader slamkit has, by the kind that selects it in a "kind:PATH" spec.
constexpr DatasetKind kKinds[] = {
    {"sim", &read_sim_log},
};

std::string kind_names() {
  std::string names;
  for (const DatasetKind& k : kKinds) names += fmt::format("{}{}", names.empty() ? "" : ", ", k.name);
  return names;
}

}  // namespace

Dataset load_dataset(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  if (colon == std::string::npos)
    throw InputError(spec, 0,
                     fmt::format("expected a dataset as KIND:PATH with KIND one of: {}", kind_names()));
  const std::string_view kind = std::string_view(spec).substr(0, colon);
  const std::string path = spec.substr(colon + 1);
  const auto match = std::find_if(std::begin(kKinds), std::end(kKinds),
                                  [&](const DatasetKind& k) { return k.name == kind; });
  if (match == std::end(kKinds))
    throw InputError(spec, 0,
                     fmt::format("unknown dataset kind '{}'; expected one of: {}", kind, kind_names()));
  if (path.empty()) throw InputError(spec, 0, fmt::format("expected a path after '{}:'", kind));
  Dataset dataset = match->read(path);
  dataset.spec = spec;
  return dataset;
}

}  // namespace slamkit
