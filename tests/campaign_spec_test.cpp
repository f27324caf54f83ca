// Campaign specs: what a spec file expands to, and how a malformed one is refused (naming the key).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>

#include "slamkit/campaign/spec.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/filters/ekf_slam.hpp"

namespace slamkit::campaign {
namespace {

using nlohmann::json;

CampaignSpec expand(const json& spec) { return parse_campaign_spec(spec, "spec.json", "."); }

/// The error a spec is refused with ("" if it is not).
std::string refusal(const json& spec) {
  try {
    expand(spec);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const json kTwoFilters = json::parse(R"({
  "name": "try",
  "datasets": [{"spec": "scenario:default", "seeds": {"from": 4, "count": 3}}],
  "filters": [{"name": "ekf", "settings": {"filter": "ekf"}},
              {"name": "fej", "settings": {"filter": "ekf", "ekf_variant": "fej"},
               "vary": {"ekf_update": ["joint", "iterated"]}}]
})");

TEST(CampaignSpec, AMemoryBudgetIsAPositiveNumberOfMegabytes) {
  json spec = kTwoFilters;
  spec["memory_per_run_mb"] = 1500;
  EXPECT_EQ(expand(spec).memory_per_run_bytes, 1.5e9);
  EXPECT_EQ(expand(kTwoFilters).memory_per_run_bytes, 0.0);
  for (const json& bad : {json(-1), json(0), json("2GB")}) {
    spec["memory_per_run_mb"] = bad;
    EXPECT_EQ(refusal(spec),
              "spec.json: memory_per_run_mb: expected a positive number of megabytes, found " + bad.dump());
  }
}

TEST(CampaignSpec, ExpandsEveryCombinationOnce) {
  const CampaignSpec spec = expand(kTwoFilters);
  EXPECT_EQ(spec.name, "try");
  ASSERT_EQ(spec.jobs.size(), 9u);  // 3 seeds x (1 + 2 variants)
  std::set<std::string> folders, configurations;
  for (const Job& job : spec.jobs) {
    folders.insert(job.folder);
    configurations.insert(job.configuration);
    EXPECT_EQ(job.spec.filter.threads, 1u) << "one core per run unless the spec says otherwise";
  }
  EXPECT_EQ(folders.size(), 9u);
  EXPECT_EQ(configurations, (std::set<std::string>{"ekf | scenario:default", "fej ekf_update=joint | scenario:default",
                                                   "fej ekf_update=iterated | scenario:default"}));
  EXPECT_EQ(spec.jobs[0].spec.dataset, "scenario:default:4");
  EXPECT_EQ(spec.jobs[2].spec.dataset, "scenario:default:6");
  EXPECT_EQ(spec.jobs[0].folder, "runs/ekf__scenario-default/seed-4");
  EXPECT_EQ(spec.jobs[0].description.at("seed"), 4);
  const Job& iterated = spec.jobs[6];
  EXPECT_EQ(iterated.configuration, "fej ekf_update=iterated | scenario:default");
  EXPECT_EQ(iterated.spec.filter.ekf_variant, EkfVariant::kFirstEstimates);
  EXPECT_EQ(iterated.spec.filter.ekf_update, EkfUpdate::kIterated);
}

TEST(CampaignSpec, FamiliesDrawWorldsAndFiltersTheirSeeds) {
  const CampaignSpec spec = expand(json::parse(R"({
    "threads_per_run": 2,
    "datasets": [{"name": "sparse", "spec": "family:sparse-cluttered", "world_seeds": [3, 9], "seeds": [1],
                  "vary": {"clutter_rate_per_scan": [0.5, 2]}}],
    "filters": [{"settings": {"filter": "fastslam2", "particles": 20, "association": {"method": "nn"}},
                 "seeds": {"from": 1, "to": 2}}]
  })"));
  ASSERT_EQ(spec.jobs.size(), 8u);  // 2 clutter rates x 2 worlds x 1 seed x 2 filter seeds
  const Job& first = spec.jobs[0];
  EXPECT_EQ(first.configuration, "fastslam2 | sparse clutter_rate_per_scan=0.5");
  EXPECT_EQ(first.spec.dataset, "family:sparse-cluttered:3:1");
  EXPECT_EQ(first.spec.dataset_settings, json::parse(R"({"clutter_rate_per_scan": 0.5})"));
  EXPECT_EQ(first.folder, "runs/fastslam2__sparse_clutter_rate_per_scan=0.5/world-3-seed-1-filter-seed-1");
  EXPECT_EQ(first.spec.filter.seed, 1u);
  EXPECT_EQ(spec.jobs[1].spec.filter.seed, 2u);
  EXPECT_EQ(first.spec.filter.particles, 20);
  EXPECT_EQ(first.spec.filter.threads, 2u);
  EXPECT_EQ(spec.jobs[7].spec.dataset, "family:sparse-cluttered:9:1");
  EXPECT_EQ(spec.jobs[7].configuration, "fastslam2 | sparse clutter_rate_per_scan=2");
}

TEST(CampaignSpec, NestedSettingsVaryByDottedKeys) {
  const CampaignSpec spec = expand(json::parse(R"({
    "datasets": [{"spec": "scenario:cluttered", "seeds": [1]}],
    "filters": [{"settings": {"association": {"method": "nn"}}, "vary": {"association.method": ["nn", "jcbb"]}}]
  })"));
  ASSERT_EQ(spec.jobs.size(), 2u);
  EXPECT_EQ(spec.jobs[1].spec.filter.association.method, AssociationMethod::kJcbb);
  EXPECT_EQ(spec.jobs[1].configuration, "ekf association.method=jcbb | scenario:cluttered");
}

TEST(CampaignSpec, MalformedSpecsAreRefusedNamingTheKey) {
  EXPECT_NE(refusal(json::parse(R"({"filters": [{}]})")).find("datasets: expected a non-empty list"),
            std::string::npos);
  json spec = kTwoFilters;
  spec["filters"][1]["vary"]["particles"] = 5;
  EXPECT_NE(refusal(spec).find("spec.json: filters[1].vary.particles: expected a non-empty list"), std::string::npos)
      << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0]["seds"] = 1;
  EXPECT_NE(refusal(spec).find("datasets[0]: unknown key 'seds' (did you mean 'seeds'?)"), std::string::npos)
      << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0]["seeds"] = json::parse(R"({"from": 3})");
  EXPECT_NE(refusal(spec).find("datasets[0].seeds: expected"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0]["seeds"] = json::parse("[1, 2, 1]");
  EXPECT_NE(refusal(spec).find("a seed is listed twice"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0] = json::parse(R"({"spec": "victoria-park", "seeds": [1]})");
  EXPECT_NE(refusal(spec).find("seeds apply to simulated datasets"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0] = json::parse(R"({"spec": "family:sparse", "seeds": [1]})");
  EXPECT_NE(refusal(spec).find("world_seeds: missing"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["datasets"][0]["spec"] = "scenario:defalt";
  EXPECT_NE(refusal(spec).find("did you mean 'default'"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["filters"][0]["settings"]["particles"] = -3;
  EXPECT_NE(refusal(spec).find("filters[0]"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["filters"][1]["name"] = "ekf";
  spec["filters"][1].erase("vary");
  EXPECT_NE(refusal(spec).find("the same configuration 'ekf | scenario:default'"), std::string::npos) << refusal(spec);
  spec = kTwoFilters;
  spec["outputs"] = "everything";
  EXPECT_NE(refusal(spec).find("outputs"), std::string::npos);
}

TEST(CampaignSpec, TheCampaignsKeptInTheRepositoryExpand) {
  const std::filesystem::path folder = std::filesystem::path(SLAMKIT_SOURCE_DIR) / "campaigns";
  const std::pair<const char*, std::size_t> expected[] = {
      {"quick.json", 20},
      {"consistency.json", 300},
      {"association.json", 240},
      {"victoria-park-sensitivity.json", 57},
      {"readme.json", 223},
      {"world-families-tuning.json", 320},
      {"world-families-test.json", 320},
      {"information-consistency.json", 800},
      {"tjtf-consistency.json", 200},
      {"grid-radish.json", 60},
      {"grid-buildings.json", 46}};
  for (const auto& [file, jobs] : expected)
    EXPECT_EQ(read_campaign_spec((folder / file).string()).jobs.size(), jobs) << file;
}

}  // namespace
}  // namespace slamkit::campaign
