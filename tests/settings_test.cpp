// The layers of a run's filter settings: defaults < the dataset's recommendation for the chosen
// filter < the association settings file < the explicit settings (flags), and what run.json is told
// took effect.
#include "slamkit/pipeline/settings.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "slamkit/core/error.hpp"
#include "slamkit/io/load_dataset.hpp"

namespace slamkit {
namespace {

std::string input_error(const SettingsSources& sources) {
  try {
    layer_settings(sources);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

/// A recommendation like Victoria Park's, for two filters.
SettingsSources recommending() {
  SettingsSources s;
  s.recommended = {{"ekf", {{"association", {{"method", "jcbb"}, {"confirm_after", 4}}}}},
                   {"fastslam2", {{"association", {{"method", "nn"}}}, {"pose_sample_fraction", 0.01}}}};
  s.recommended_source = "park.json";
  return s;
}

TEST(LayerSettings, WithoutSourcesTheDefaults) {
  const LayeredSettings layered = layer_settings({});
  EXPECT_EQ(to_json(layered.config), to_json(FilterConfig{}));
  EXPECT_TRUE(layered.recommendation_applied.empty());
}

TEST(LayerSettings, TheChosenFiltersRecommendationLiesAboveTheDefaults) {
  SettingsSources s = recommending();
  s.explicit_settings = {{"filter", "fastslam2"}};
  const LayeredSettings layered = layer_settings(s);
  EXPECT_EQ(layered.config.filter, FilterKind::kFastSlam2);
  EXPECT_EQ(layered.config.pose_sample_fraction, 0.01);
  EXPECT_EQ(layered.config.association.method, AssociationMethod::kNearestNeighbour);
  EXPECT_EQ(layered.config.association.confirm_after, AssociationConfig{}.confirm_after);  // the ekf's is not used
  EXPECT_EQ(layered.recommendation_applied, s.recommended["fastslam2"]);

  // Without "filter" the default filter's recommendation applies.
  s.explicit_settings = nlohmann::json::object();
  const LayeredSettings ekf = layer_settings(s);
  EXPECT_EQ(ekf.config.association.method, AssociationMethod::kJcbb);
  EXPECT_EQ(ekf.config.association.confirm_after, 4);
  EXPECT_EQ(ekf.config.pose_sample_fraction, FilterConfig{}.pose_sample_fraction);

  // A filter with no recommendation gets none.
  s.explicit_settings = {{"filter", "ukf"}};
  SettingsSources plain;
  plain.explicit_settings = s.explicit_settings;
  EXPECT_EQ(to_json(layer_settings(s).config), to_json(layer_settings(plain).config));
  EXPECT_TRUE(layer_settings(s).recommendation_applied.empty());
}

TEST(LayerSettings, TheAssociationFileLiesAboveTheRecommendationAndTheFlagsAboveBoth) {
  SettingsSources s = recommending();
  s.association = {{"accept_probability", 0.95}, {"confirm_after", 5}, {"method", "nn"}};
  s.association_source = "assoc.json";
  const LayeredSettings file = layer_settings(s);
  EXPECT_EQ(file.config.association.method, AssociationMethod::kNearestNeighbour);  // the file's
  EXPECT_EQ(file.config.association.confirm_after, 5);                                // the file's
  EXPECT_EQ(file.config.association.accept_probability, 0.95);
  // The file names every key the recommendation set: none of it took effect.
  EXPECT_TRUE(file.recommendation_applied.empty()) << file.recommendation_applied.dump();

  s.association = {{"accept_probability", 0.95}};
  s.explicit_settings = {{"association", {{"method", "known"}}}, {"particles", 7}};
  const LayeredSettings flags = layer_settings(s);
  EXPECT_EQ(flags.config.association.method, AssociationMethod::kKnown);  // the flag's
  EXPECT_EQ(flags.config.association.confirm_after, 4);                    // the recommendation's
  EXPECT_EQ(flags.config.association.accept_probability, 0.95);            // the file's
  EXPECT_EQ(flags.config.particles, 7);
  EXPECT_EQ(flags.recommendation_applied, (nlohmann::json{{"association", {{"confirm_after", 4}}}}));
}

TEST(LayerSettings, EveryFiltersRecommendationIsCheckedAndNamesItsSource) {
  SettingsSources s = recommending();
  s.recommended["fastslam3"] = nlohmann::json::object();
  EXPECT_NE(input_error(s).find("park.json: in 'recommended': unknown filter 'fastslam3' (did you mean "
                                "'fastslam1' or 'fastslam2'?)"),
            std::string::npos)
      << input_error(s);

  s = recommending();
  s.recommended["ukf"] = {{"ukf_nosie", "additive"}};  // not the chosen filter's, still checked
  EXPECT_NE(input_error(s).find("park.json (recommended.ukf): unknown key 'ukf_nosie' in the filter settings "
                                "(did you mean 'ukf_noise'?)"),
            std::string::npos)
      << input_error(s);

  s = recommending();
  s.recommended["ekf"] = {{"filter", "ukf"}};
  EXPECT_NE(input_error(s).find("cannot choose the filter"), std::string::npos) << input_error(s);

  s = recommending();
  s.recommended = nlohmann::json::array();
  EXPECT_NE(input_error(s).find("park.json: expected the recommended settings as an object"), std::string::npos);

  s = recommending();
  s.association = {{"confirm_afterr", 2}};
  s.association_source = "assoc.json";
  EXPECT_NE(input_error(s).find("assoc.json: unknown key 'confirm_afterr'"), std::string::npos) << input_error(s);
}

TEST(LayerSettings, SettingsNoFilterRunsWithAreAUsageError) {
  SettingsSources s = recommending();
  s.explicit_settings = {{"filter", "fastslam2"}, {"landmark_init", "inverse-distance"}};
  try {
    layer_settings(s);
    ADD_FAILURE() << "FastSLAM does not keep inverse-distance landmarks";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("kept by the filter 'ekf'"), std::string::npos) << e.what();
  }
  s.explicit_settings = {{"particles", 0}};
  EXPECT_THROW(layer_settings(s), std::invalid_argument);
}

// Victoria Park has no landmark identities: every filter gets an association method from it, and the
// settings chosen on the park (docs/choosing.md) for the UKF and FastSLAM 2.0.
TEST(LayerSettings, VictoriaParksBuiltInRecommendation) {
  SettingsSources s;
  s.recommended = recommended_settings("victoria-park:/data/vp", nullptr, "");
  for (const char* filter : {"ekf", "ukf", "fastslam1", "fastslam2"}) {
    s.explicit_settings = {{"filter", filter}};
    const FilterConfig config = layer_settings(s).config;
    EXPECT_NE(config.association.method, AssociationMethod::kKnown) << filter;
  }
  s.explicit_settings = {{"filter", "ukf"}};
  EXPECT_EQ(layer_settings(s).config.ukf_noise, UkfNoise::kAdditive);
  s.explicit_settings = {{"filter", "fastslam2"}};
  EXPECT_EQ(layer_settings(s).config.pose_sample_fraction, 0.01);
  s.explicit_settings = {{"filter", "fastslam2"}, {"pose_sample_fraction", 1.0}};
  EXPECT_EQ(layer_settings(s).config.pose_sample_fraction, 1.0);

  // Simulated logs and MRCLAM recommend nothing; a settings file without "recommended" neither.
  EXPECT_TRUE(recommended_settings("sim:/x", nullptr, "").empty());
  EXPECT_TRUE(recommended_settings("mrclam:/x:robot2", nullptr, "").empty());
  EXPECT_TRUE(recommended_settings("victoria-park:/x", nlohmann::json{{"max_range_m", 20}}, "f.json").empty());
  EXPECT_THROW(recommended_settings("victoria-park:/x", nlohmann::json{{"recommended", 3}}, "f.json"), InputError);
}

}  // namespace
}  // namespace slamkit
