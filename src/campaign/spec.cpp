#include "slamkit/campaign/spec.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/io/simulated_datasets.hpp"

namespace slamkit::campaign {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Far beyond any campaign one machine or cluster runs, and a guard against a typo's billion jobs.
constexpr std::uint64_t kMaxSeeds = 1'000'000;
constexpr std::size_t kMaxJobs = 10'000'000;

/// Errors name the spec and the key, as a path into the file: "filters[1].vary.particles".
class Where {
 public:
  Where(std::string source, std::string key) : source_(std::move(source)), key_(std::move(key)) {}
  Where operator[](std::string_view child) const {
    return {source_, key_.empty() ? std::string(child) : fmt::format("{}.{}", key_, child)};
  }
  Where operator[](std::size_t index) const { return {source_, fmt::format("{}[{}]", key_, index)}; }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(source_, 0, key_.empty() ? what : fmt::format("{}: {}", key_, what));
  }
  const std::string& source() const { return source_; }
  const std::string& key() const { return key_; }

 private:
  std::string source_, key_;
};

void require_keys(const json& object, const std::vector<std::string>& allowed, const Where& where) {
  if (!object.is_object()) where.fail(fmt::format("expected an object, found {}", object.dump()));
  for (const auto& [key, value] : object.items())
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
      where.fail(unknown_name_message("key", key, allowed));
}

std::string string_at(const json& object, const std::string& key, const Where& where, std::string fallback) {
  if (!object.contains(key)) return fallback;
  const json& value = object.at(key);
  if (!value.is_string() || value.get<std::string>().empty())
    where[key].fail(fmt::format("expected a non-empty string, found {}", value.dump()));
  return value.get<std::string>();
}

/// JSON text gives an unsigned number for 3, a program building the spec (Python's dict) a signed one.
std::uint64_t whole_number(const json& value, const Where& where) {
  if (!value.is_number_unsigned() && !(value.is_number_integer() && value.get<std::int64_t>() >= 0))
    where.fail(fmt::format("expected a whole number >= 0, found {}", value.dump()));
  return value.get<std::uint64_t>();
}

/// [1, 2, 5], {"from": 1, "count": 50} or {"from": 1, "to": 50}.
std::vector<std::uint64_t> seeds_at(const json& value, const Where& where) {
  std::vector<std::uint64_t> seeds;
  if (value.is_array()) {
    if (value.empty()) where.fail("expected at least one seed");
    for (std::size_t i = 0; i < value.size(); ++i) seeds.push_back(whole_number(value[i], where[i]));
  } else if (value.is_object()) {
    require_keys(value, {"from", "count", "to"}, where);
    if (!value.contains("from") || value.contains("count") == value.contains("to"))
      where.fail("expected {\"from\": FIRST, \"count\": N} or {\"from\": FIRST, \"to\": LAST}");
    const std::uint64_t from = whole_number(value.at("from"), where["from"]);
    std::uint64_t count = 0;
    if (value.contains("count")) {
      count = whole_number(value.at("count"), where["count"]);
    } else {
      const std::uint64_t to = whole_number(value.at("to"), where["to"]);
      if (to < from) where["to"].fail("before 'from'");
      count = to - from + 1;
    }
    if (count == 0 || count > kMaxSeeds) where.fail(fmt::format("expected 1 to {} seeds, found {}", kMaxSeeds, count));
    if (from > std::numeric_limits<std::uint64_t>::max() - (count - 1)) where.fail("the last seed is beyond 2^64 - 1");
    for (std::uint64_t i = 0; i < count; ++i) seeds.push_back(from + i);
  } else {
    where.fail(fmt::format("expected a list of seeds or {{\"from\": FIRST, \"count\": N}}, found {}", value.dump()));
  }
  std::vector<std::uint64_t> sorted = seeds;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) where.fail("a seed is listed twice");
  return seeds;
}

/// One combination of varied values: its words for labels and its patch of the settings.
struct Variant {
  std::string words;  // " clutter_rate=1 loops=2"
  json patch = json::object();
};

/// "association.method" = "nn" as {"association": {"method": "nn"}}.
void set_dotted(json& patch, const std::string& dotted, const json& value) {
  json* at = &patch;
  std::size_t begin = 0;
  for (std::size_t dot = dotted.find('.'); dot != std::string::npos; dot = dotted.find('.', begin)) {
    at = &(*at)[dotted.substr(begin, dot - begin)];
    begin = dot + 1;
  }
  (*at)[dotted.substr(begin)] = value;
}

std::string value_words(const json& value) { return value.is_string() ? value.get<std::string>() : value.dump(); }

void check_key(const std::string& key, const Where& where) {
  if (key.empty() || key.front() == '.' || key.back() == '.' || key.find("..") != std::string::npos)
    where.fail("expected a settings key, with dots between nested keys");
}

/// The variants of a "vary" entry: an object of lists gives every combination of their values (keys in
/// the file's sorted order); a list of objects gives each object as one variant (one setting changed at
/// a time, say). Without one, a single variant that changes nothing.
std::vector<Variant> variants_at(const json& object, const Where& where) {
  std::vector<Variant> variants(1);
  if (!object.contains("vary")) return variants;
  const json& vary = object.at("vary");
  if (vary.is_array() && !vary.empty()) {
    variants.clear();
    for (std::size_t i = 0; i < vary.size(); ++i) {
      if (!vary[i].is_object() || vary[i].empty())
        where["vary"][i].fail(fmt::format("expected an object of settings, found {}", vary[i].dump()));
      Variant v;
      for (const auto& [key, value] : vary[i].items()) {
        check_key(key, where["vary"][i][key]);
        v.words += fmt::format(" {}={}", key, value_words(value));
        set_dotted(v.patch, key, value);
      }
      variants.push_back(std::move(v));
    }
    return variants;
  }
  if (!vary.is_object() || vary.empty())
    where["vary"].fail("expected an object of lists of values (every combination) or a list of settings objects");
  for (const auto& [key, values] : vary.items()) {
    if (!values.is_array() || values.empty()) where["vary"][key].fail("expected a non-empty list of values");
    check_key(key, where["vary"][key]);
    std::vector<Variant> next;
    for (const Variant& v : variants)
      for (const json& value : values) {
        Variant combined = v;
        combined.words += fmt::format(" {}={}", key, value_words(value));
        set_dotted(combined.patch, key, value);
        next.push_back(std::move(combined));
      }
    variants = std::move(next);
  }
  return variants;
}

/// Letters, digits and ._=- kept, a space as '_', anything else as '-'.
std::string file_name(const std::string& text) {
  std::string name;
  for (char c : text) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '=' || c == '-';
    name += keep ? c : c == ' ' ? '_' : '-';
  }
  return name;
}

struct DatasetEntry {
  std::string name, spec;
  std::vector<std::optional<std::uint64_t>> world_seeds{std::nullopt}, seeds{std::nullopt};
  json settings;  // null: the reader's defaults
  std::string settings_source;
  std::vector<Variant> variants;
};

DatasetEntry dataset_entry(const json& entry, const Where& where, const std::string& base_folder) {
  require_keys(entry, {"name", "spec", "seeds", "world_seeds", "settings", "settings_file", "vary"}, where);
  DatasetEntry d;
  d.spec = string_at(entry, "spec", where, "");
  if (d.spec.empty()) where["spec"].fail("missing; expected a dataset spec, e.g. \"scenario:default\"");
  d.name = string_at(entry, "name", where, d.spec);
  const std::string kind = d.spec.substr(0, d.spec.find(':'));
  const auto seed_list = [&](const char* key) {
    std::vector<std::optional<std::uint64_t>> list;
    for (std::uint64_t s : seeds_at(entry.at(key), where[key])) list.emplace_back(s);
    return list;
  };
  if (entry.contains("seeds")) {
    if (!is_simulated_kind(kind))
      where["seeds"].fail(
          fmt::format("seeds apply to simulated datasets (scenario:, family:, building:), not {}:", kind));
    d.seeds = seed_list("seeds");
  }
  if (entry.contains("world_seeds") != (kind == "family"))
    where["world_seeds"].fail(
        kind == "family" ? "missing; a world family needs the worlds to draw (e.g. {\"from\": 1, \"count\": 10})"
                         : "world seeds apply to world families (family:NAME) only");
  if (kind == "family") d.world_seeds = seed_list("world_seeds");
  if (entry.contains("settings") && entry.contains("settings_file"))
    where.fail("expected 'settings' or 'settings_file', not both");
  if (entry.contains("settings")) {
    d.settings = entry.at("settings");
    if (!d.settings.is_object()) where["settings"].fail("expected an object of dataset settings");
    d.settings_source = fmt::format("{}: {}.settings", where.source(), where.key());
  } else if (entry.contains("settings_file")) {
    const fs::path file = string_at(entry, "settings_file", where, "");
    d.settings_source = (file.is_absolute() ? file : fs::path(base_folder) / file).lexically_normal().string();
    d.settings = read_json_file(d.settings_source);
  }
  d.variants = variants_at(entry, where);
  return d;
}

struct FilterEntry {
  std::string name;
  json settings = json::object();
  json association;  // an association settings file's contents (run --assoc-config); null for none
  std::string association_source;
  std::vector<std::optional<std::uint64_t>> seeds{std::nullopt};
  /// "seeds": "dataset": each run's filter seed is its dataset's noise seed (its world seed where it has
  /// none), so that the particles' draws change with the data as a script's `--seed $seed` did.
  bool seeds_follow_dataset = false;
  std::vector<Variant> variants;
};

FilterEntry filter_entry(const json& entry, const Where& where, const std::string& base_folder) {
  require_keys(entry, {"name", "settings", "association_file", "seeds", "vary"}, where);
  FilterEntry f;
  if (entry.contains("association_file")) {
    const fs::path file = string_at(entry, "association_file", where, "");
    f.association_source = (file.is_absolute() ? file : fs::path(base_folder) / file).lexically_normal().string();
    f.association = read_json_file(f.association_source);
  }
  if (entry.contains("settings")) {
    f.settings = entry.at("settings");
    if (!f.settings.is_object()) where["settings"].fail("expected an object of run.json's settings keys");
  }
  const json filter = f.settings.value("filter", json("ekf"));
  f.name = string_at(entry, "name", where, filter.is_string() ? filter.get<std::string>() : "ekf");
  if (entry.contains("seeds") && entry.at("seeds") == "dataset") {
    f.seeds_follow_dataset = true;
  } else if (entry.contains("seeds")) {
    f.seeds.clear();
    for (std::uint64_t s : seeds_at(entry.at("seeds"), where["seeds"])) f.seeds.emplace_back(s);
  }
  f.variants = variants_at(entry, where);
  return f;
}

/// The dataset spec with its seeds: "family:sparse" with world 3 and seed 7 is "family:sparse:3:7".
std::string seeded_spec(const std::string& spec, std::optional<std::uint64_t> world,
                        std::optional<std::uint64_t> seed) {
  std::string seeded = spec;
  if (world) seeded += fmt::format(":{}", *world);
  if (seed) seeded += fmt::format(":{}", *seed);
  return seeded;
}

std::string instance_name(std::optional<std::uint64_t> world, std::optional<std::uint64_t> seed,
                          std::optional<std::uint64_t> filter_seed) {
  std::string name;
  const auto add = [&](const char* prefix, std::optional<std::uint64_t> value) {
    if (value) name += fmt::format("{}{}{}", name.empty() ? "" : "-", prefix, *value);
  };
  add("world-", world);
  add("seed-", seed);
  add("filter-seed-", filter_seed);
  return name.empty() ? "run" : name;
}

template <class Entry, class Read>
std::vector<Entry> entries_at(const json& spec, const char* key, const Where& where, Read read) {
  if (!spec.contains(key) || !spec.at(key).is_array() || spec.at(key).empty())
    where[key].fail("expected a non-empty list");
  std::vector<Entry> entries;
  for (std::size_t i = 0; i < spec.at(key).size(); ++i) entries.push_back(read(spec.at(key)[i], where[key][i]));
  return entries;
}

}  // namespace

namespace {

/// The jobs of one list of datasets by one list of filters (the spec's, or one of its groups'),
/// appended to `campaign`. `folders` holds every job folder so far, with where it came from.
void expand_group(const json& group, const Where& where, const std::string& base_folder, CampaignSpec& campaign,
                  std::map<std::string, std::string>& folders) {
  const auto datasets = entries_at<DatasetEntry>(
      group, "datasets", where, [&](const json& e, const Where& w) { return dataset_entry(e, w, base_folder); });
  const auto filters = entries_at<FilterEntry>(
      group, "filters", where, [&](const json& e, const Where& w) { return filter_entry(e, w, base_folder); });
  for (std::size_t di = 0; di < datasets.size(); ++di) {
    const DatasetEntry& d = datasets[di];
    for (const Variant& dv : d.variants)
      for (std::size_t fi = 0; fi < filters.size(); ++fi) {
        const FilterEntry& f = filters[fi];
        for (const Variant& fv : f.variants) {
          const std::string filter_entry = f.name + fv.words, dataset_entry = d.name + dv.words;
          const std::string configuration = fmt::format("{} | {}", filter_entry, dataset_entry);
          json dataset_settings = d.settings;
          if (!dv.patch.empty()) {
            if (dataset_settings.is_null()) dataset_settings = json::object();
            dataset_settings.merge_patch(dv.patch);
          }
          json settings = f.settings;
          settings.merge_patch(fv.patch);
          if (!settings.contains("threads")) settings["threads"] = campaign.threads_per_run;
          const std::string origin =
              fmt::format("{}filters[{}] on datasets[{}]", where.key().empty() ? "" : where.key() + ".", fi, di);
          for (const auto world : d.world_seeds)
            for (const auto seed : d.seeds)
              for (auto filter_seed : f.seeds) {
                if (f.seeds_follow_dataset) filter_seed = seed ? seed : world;
                if (filter_seed) settings["seed"] = *filter_seed;
                Job job;
                job.configuration = configuration;
                job.filter_entry = filter_entry;
                job.dataset_entry = dataset_entry;
                job.folder = (fs::path("runs") / (file_name(filter_entry) + "__" + file_name(dataset_entry)) /
                              instance_name(world, seed, f.seeds_follow_dataset ? std::nullopt : filter_seed))
                                 .string();
                if (const auto [it, fresh] = folders.emplace(job.folder, origin); !fresh)
                  where.fail(fmt::format("{} and {} give the same configuration '{}'; give them different names",
                                         it->second, origin, configuration));
                SettingsSources sources;
                sources.association = f.association;
                sources.association_source = f.association_source;
                sources.explicit_settings = settings;
                sources.explicit_source = fmt::format("{}: {}", where.source(), origin);
                const std::string dataset_source =
                    d.settings_source.empty() ? fmt::format("{}: {}", where.source(), origin) : d.settings_source;
                try {
                  job.spec = make_run_spec(seeded_spec(d.spec, world, seed), dataset_settings, dataset_source,
                                           std::move(sources));
                } catch (const std::invalid_argument& e) {
                  Where(where.source(), origin).fail(e.what());
                }
                job.description = {{"campaign", campaign.name}, {"configuration", configuration},
                                   {"filter", f.name},          {"dataset", d.name},
                                   {"filter_vary", fv.patch},   {"dataset_vary", dv.patch}};
                if (world) job.description["world_seed"] = *world;
                if (seed) job.description["seed"] = *seed;
                if (filter_seed) job.description["filter_seed"] = *filter_seed;
                campaign.jobs.push_back(std::move(job));
                if (campaign.jobs.size() > kMaxJobs)
                  where.fail(fmt::format("more than {} jobs; split the campaign", kMaxJobs));
              }
        }
      }
  }
}

/// A table's rows and columns name entries the campaign has, so a misspelt one fails before the runs
/// rather than in the report at their end.
void check_table_entries(const CampaignSpec& campaign, const Where& where) {
  std::vector<std::string> filter_entries, dataset_entries;
  const auto add = [](std::vector<std::string>& list, std::string entry) {
    if (std::find(list.begin(), list.end(), entry) == list.end()) list.push_back(std::move(entry));
  };
  for (const Job& job : campaign.jobs) {
    add(filter_entries, job.filter_entry);
    add(dataset_entries, job.dataset_entry);
  }
  for (std::size_t t = 0; t < campaign.tables.size(); ++t) {
    const TableSpec& table = campaign.tables[t];
    const bool filter_rows = table.rows_are == "filter";
    for (const auto& [side, lines, filters] : {std::tuple{"rows", &table.rows, filter_rows},
                                               std::tuple{"columns", &table.columns, !filter_rows}})
      for (std::size_t i = 0; i < lines->size(); ++i) {
        const std::vector<std::string>& known = filters ? filter_entries : dataset_entries;
        if (std::find(known.begin(), known.end(), (*lines)[i].key) == known.end())
          where[t][side][i].fail(unknown_name_message(filters ? "filter entry" : "dataset entry", (*lines)[i].key, known));
      }
  }
}

}  // namespace

CampaignSpec parse_campaign_spec(const json& spec, const std::string& source, const std::string& base_folder) {
  const Where top(source, "");
  require_keys(spec, {"name", "outputs", "threads_per_run", "memory_per_run_mb", "datasets", "filters", "groups", "tables"},
               top);
  CampaignSpec campaign;
  campaign.source = spec;
  campaign.name = string_at(spec, "name", top, fs::path(source).stem().string());
  const std::string outputs = string_at(spec, "outputs", top, "folder");
  if (outputs != "folder" && outputs != "metrics")
    top["outputs"].fail(unknown_name_message("outputs", outputs, {"folder", "metrics"}));
  campaign.outputs = outputs == "folder" ? RunOutputs::kFolder : RunOutputs::kMetrics;
  if (spec.contains("threads_per_run")) {
    const std::uint64_t threads = whole_number(spec.at("threads_per_run"), top["threads_per_run"]);
    if (threads < 1 || threads > 1024) top["threads_per_run"].fail("expected 1 to 1024");
    campaign.threads_per_run = static_cast<unsigned>(threads);
  }
  if (spec.contains("memory_per_run_mb")) {
    const json& mb = spec.at("memory_per_run_mb");
    if (!mb.is_number() || !(mb.get<double>() > 0.0) || !std::isfinite(mb.get<double>()))
      top["memory_per_run_mb"].fail(fmt::format("expected a positive number of megabytes, found {}", mb.dump()));
    campaign.memory_per_run_bytes = mb.get<double>() * 1e6;
  }
  std::map<std::string, std::string> folders;
  if (!spec.contains("groups")) {
    expand_group(spec, top, base_folder, campaign, folders);
  } else {
    if (spec.contains("datasets") || spec.contains("filters"))
      top.fail("expected 'groups' or 'datasets' and 'filters', not both");
    const json& groups = spec.at("groups");
    if (!groups.is_array() || groups.empty()) top["groups"].fail("expected a non-empty list of {datasets, filters}");
    for (std::size_t i = 0; i < groups.size(); ++i) {
      require_keys(groups[i], {"datasets", "filters"}, top["groups"][i]);
      expand_group(groups[i], top["groups"][i], base_folder, campaign, folders);
    }
  }
  if (spec.contains("tables")) {
    campaign.tables = parse_report_tables(spec.at("tables"), source);
    check_table_entries(campaign, top["tables"]);
  }
  return campaign;
}

CampaignSpec read_campaign_spec(const std::string& path) {
  return parse_campaign_spec(read_json_file(path), path, fs::path(path).parent_path().string());
}

}  // namespace slamkit::campaign
