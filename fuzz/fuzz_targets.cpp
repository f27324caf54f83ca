#include "fuzz_targets.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/text_reader.hpp"
#include "slamkit/io/carmen.hpp"
#include "slamkit/io/course_log.hpp"
#include "slamkit/io/mrclam.hpp"
#include "slamkit/io/run_io.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "slamkit/io/victoria_park.hpp"
#include "slamkit/models/acfr_car.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace fs = std::filesystem;

namespace slamkit::fuzz {
namespace {

/// A folder of this process's own under the temporary directory, emptied for every input and
/// removed at exit; the readers under test take paths.
class Scratch {
 public:
  Scratch() : root_(fs::temp_directory_path() / ("slamkit-fuzz-" + std::to_string(::getpid()))) {}
  ~Scratch() {
    std::error_code ignored;
    fs::remove_all(root_, ignored);
  }
  /// An empty folder.
  const fs::path& fresh() {
    fs::remove_all(root_);
    fs::create_directories(root_);
    return root_;
  }

 private:
  fs::path root_;
};

const fs::path& fresh_folder() {
  static Scratch scratch;
  return scratch.fresh();
}

void write_file(const fs::path& path, std::string_view contents) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  if (!out) throw std::runtime_error("cannot write the fuzz input to " + path.string());
}

/// Writes the parts of `input` (separated by kFileSeparator) to `names` in `dir`, in order; names
/// beyond the parts given are not written.
void write_files(const fs::path& dir, std::string_view input, std::initializer_list<const char*> names) {
  for (const char* name : names) {
    const std::size_t end = input.find(kFileSeparator);
    write_file(dir / name, input.substr(0, end));
    if (end == std::string_view::npos) return;
    input.remove_prefix(end + kFileSeparator.size());
  }
}

/// Runs `f`; bad input may end it with InputError, which is the documented way to refuse it.
template <typename F>
void refusing_only_with_input_error(F&& f) {
  try {
    f();
  } catch (const InputError&) {
  }
}

/// One file: `input` itself.
fs::path single_file(std::string_view input, const char* name) {
  const fs::path path = fresh_folder() / name;
  write_file(path, input);
  return path;
}

void sim_log(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input,
              {"params.json", "events.txt", "truth_poses.txt", "truth_landmarks.txt", "truth_observations.txt",
               "world.txt"});
  refusing_only_with_input_error([&] { read_sim_log(dir.string()); });
}

void course_log(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input, {"sensor_data.dat", "world.dat"});
  refusing_only_with_input_error([&] { read_course_log(dir.string()); });
}

void mrclam(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input,
              {"Barcodes.dat", "Robot1_Odometry.dat", "Robot1_Measurement.dat", "Landmark_Groundtruth.dat",
               "Robot1_Groundtruth.dat"});
  refusing_only_with_input_error([&] { read_mrclam(dir.string(), 1); });
}

void victoria_park(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input, {"DRS.txt", "GPS.txt", "LASER.txt.gz"});
  refusing_only_with_input_error([&] { read_victoria_park(dir.string()); });
}

/// A CARMEN log, then the reference log beside it.
void carmen(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input, {"log.log", "log.reference.log"});
  refusing_only_with_input_error([&] { read_carmen((dir / "log.log").string()); });
}

void world(std::string_view input) {
  const fs::path path = single_file(input, "world.txt");
  refusing_only_with_input_error([&] { read_world(path.string()); });
}

/// The trajectory formats; the first byte chooses the reader.
void trajectory(std::string_view input) {
  if (input.empty()) return;
  const char kind = input.front();
  const fs::path path = single_file(input.substr(1), "trajectory.txt");
  refusing_only_with_input_error([&] {
    switch (static_cast<unsigned char>(kind) % 3) {
      case 0: read_tum(path.string()); break;
      case 1: read_pose_covariances(path.string()); break;
      default: read_map(path.string()); break;
    }
  });
}

/// Every settings table; the first byte chooses the table.
void json_settings(std::string_view input) {
  if (input.empty()) return;
  const char kind = input.front();
  const std::string text(input.substr(1));
  refusing_only_with_input_error([&] {
    const nlohmann::json json = parse_json(text, "settings.json");
    switch (static_cast<unsigned char>(kind) % 6) {
      case 0: simulator_config_from_json(json, "settings.json"); break;
      case 1: course_options_from_json(json, "settings.json"); break;
      case 2: mrclam_options_from_json(json, "settings.json"); break;
      case 3: victoria_park_options_from_json(json, "settings.json"); break;
      case 4: association_config_from_json(json, "settings.json"); break;
      default: filter_config_from_json(json, "settings.json"); break;
    }
  });
}

void run_folder(std::string_view input) {
  const fs::path& dir = fresh_folder();
  write_files(dir, input,
              {"run.json", "trajectory.tum", "filtered.tum", "pose_covariance.txt", "dead_reckoning.tum", "map.txt",
               "landmark_std.txt", "associations.txt", "particles.txt"});
  refusing_only_with_input_error([&] { read_run(dir.string()); });
}

/// TextReader on plain or gzip-compressed bytes: every line's fields as numbers and integers.
void text(std::string_view input) {
  const fs::path path = single_file(input, "text.txt.gz");
  refusing_only_with_input_error([&] {
    TextReader in(path.string());
    while (in.next()) {
      for (std::size_t i = 0; i < in.size(); ++i) {
        double number = 0.0;
        long integer = 0;
        parse_double(in.field(i), number);
        parse_long(in.field(i), integer);
      }
      if (in.size() >= 2) {
        in.number(0, "a number");
        in.integer(1, "an integer");
      }
    }
  });
}

/// Reads typed values from the fuzz input, running out gracefully (zeros) at its end.
class Bytes {
 public:
  explicit Bytes(std::string_view data) : data_(data) {}
  bool empty() const { return data_.empty(); }
  std::uint8_t byte() {
    if (data_.empty()) return 0;
    const auto b = static_cast<std::uint8_t>(data_.front());
    data_.remove_prefix(1);
    return b;
  }
  /// Mostly ordinary values, and often the ones that break arithmetic.
  double number() {
    static constexpr double kSpecial[] = {std::numeric_limits<double>::quiet_NaN(),
                                          std::numeric_limits<double>::infinity(),
                                          -std::numeric_limits<double>::infinity(),
                                          1e300,
                                          -1e300,
                                          0.0,
                                          1e5,
                                          -1.0,
                                          std::numeric_limits<double>::denorm_min(),
                                          9.2e18};
    const std::uint8_t kind = byte();
    if (kind < std::size(kSpecial)) return kSpecial[kind];
    if (kind < 16) {  // any bit pattern
      double raw = 0.0;
      char bits[sizeof raw] = {};
      for (char& b : bits) b = static_cast<char>(byte());
      std::memcpy(&raw, bits, sizeof raw);
      return raw;
    }
    const auto high = byte(), low = byte();
    return static_cast<double>(static_cast<std::int16_t>(high << 8 | low)) / 64.0;
  }

 private:
  std::string_view data_;
};

struct Platform {
  std::shared_ptr<const MotionModel> motion;
  SensorLimits sensor;
};

Platform platform(std::uint8_t choice) {
  switch (choice % 4) {
    case 0: return {std::make_shared<const AckermannModel>(AckermannModel::Params{}), SensorLimits{30.0, 2.0}};
    case 1: return {std::make_shared<const OdometryModel>(CourseOptions{}.motion), CourseOptions{}.sensor};
    case 2: return {std::make_shared<const VelocityModel>(MrclamOptions{}.motion), MrclamOptions{}.sensor};
    default: return {std::make_shared<const AcfrCarModel>(VictoriaParkOptions{}.car), SensorLimits{30.0, 3.14}};
  }
}

/// A filter chosen by the first bytes, run by the pipeline's runner on the events the rest
/// describes: arbitrary times (gaps, out of order), controls and observations, NaN, infinities and
/// huge values included. The runner must refuse what it cannot run with an InputError; what it runs
/// must end with a finite estimate.
void filter_pipeline(std::string_view input) {
  Bytes in(input);
  FilterConfig config;
  const std::uint8_t choice = in.byte();
  // Every landmark filter: EKF, UKF, FastSLAM 1.0 and 2.0, or, where choice / 24 is odd (so that the
  // older seeds keep their meaning), EIF, SEIF, ESEIF and TJTF.
  config.filter = static_cast<FilterKind>(choice % 4 + (choice / 24 % 2 == 1 ? 4 : 0));
  config.association.method = static_cast<AssociationMethod>(choice / 4 % 3);
  if (config.association.method == AssociationMethod::kJcbb &&
      (config.filter == FilterKind::kFastSlam1 || config.filter == FilterKind::kFastSlam2))
    config.association.method = AssociationMethod::kNearestNeighbour;
  config.ekf_update = choice / 12 % 2 == 0 ? EkfUpdate::kJoint : EkfUpdate::kSequential;
  const std::uint8_t variant = in.byte();
  if (config.filter == FilterKind::kEkf) config.ekf_variant = static_cast<EkfVariant>(variant % 4);
  if (config.ekf_variant == EkfVariant::kCompressed) config.ekf_update = EkfUpdate::kSequential;
  if (config.filter == FilterKind::kEseif) config.ekf_update = EkfUpdate::kJoint;  // its relocation needs the scan
  config.particles = 1 + variant / 4 % 8;
  config.threads = 1;

  Dataset dataset;
  dataset.spec = "fuzz";
  const Platform p = platform(in.byte());
  dataset.motion = p.motion;
  dataset.sensor = p.sensor;
  dataset.observation = std::make_shared<const RangeBearingModel>(RangeBearingModel::Params{});
  double t = 0.0;
  constexpr std::size_t kMaxEvents = 64;  // enough for every path; more only slows the fuzzer
  while (!in.empty() && dataset.events.size() < kMaxEvents) {
    const std::uint8_t tag = in.byte();
    t += tag & 1 ? 0.0 : in.number();
    if (tag & 2) {
      ControlEvent control;
      control.t = t;
      control.dt = in.number();
      control.u.resize(p.motion->control_dim());
      for (Eigen::Index i = 0; i < control.u.size(); ++i) control.u(i) = in.number();
      dataset.events.emplace_back(control);
    } else {
      ScanEvent scan;
      scan.t = t;
      for (int k = tag >> 2 & 7; k > 0; --k) {
        const std::uint8_t id = in.byte();
        const double range = in.number(), bearing = in.number();
        scan.observations.push_back({Vector2(range, bearing), id < 128 ? kUnknownId : id % 16});
      }
      dataset.events.emplace_back(std::move(scan));
    }
  }
  refusing_only_with_input_error([&] {
    const auto filter = make_filter(config, dataset);
    // A run may end as diverged (its estimate not finite, or its numbers broken down); one that does
    // not must end with a finite estimate.
    if (run_filter(*filter, dataset).diverged_at_s) return;
    if (!filter->pose().allFinite() || !filter->pose_covariance().allFinite())
      throw std::logic_error("the filter's estimate is not finite after a run the runner accepted");
  });
}

/// The grid filters (scan matching, grid FastSLAM with a few particles) run on arbitrary laser scans
/// and controls: beam geometries, ranges (NaN, infinite, negative, beyond the maximum), times. As
/// for filter_pipeline, the runner refuses what it cannot run with an InputError, and a run it
/// accepts ends with a finite pose.
void grid_pipeline(std::string_view input) {
  Bytes in(input);
  FilterConfig config;
  const std::uint8_t choice = in.byte();
  config.filter = choice % 2 == 0 ? FilterKind::kScanMatching : FilterKind::kGridFastSlam;
  config.particles = 1 + choice / 2 % 4;
  config.threads = 1;
  // Coarse cells and short rays: the fuzzer's time goes to the inputs, not to tracing rays.
  config.grid.grid.resolution = 0.25;
  config.grid.grid.range_cutoff = 5.0;
  // A map of at most 250 m x 250 m: poses far apart are refused (GridExtentError, reported as an
  // InputError) before the tile table spans them.
  config.grid.grid.max_cells = 1e6;

  Dataset dataset;
  dataset.spec = "fuzz";
  const Platform p = platform(in.byte());
  dataset.motion = p.motion;
  dataset.sensor = p.sensor;
  double t = 0.0;
  constexpr std::size_t kMaxEvents = 32;
  while (!in.empty() && dataset.events.size() < kMaxEvents) {
    const std::uint8_t tag = in.byte();
    t += tag & 1 ? 0.0 : in.number();
    if (tag & 2) {
      ControlEvent control;
      control.t = t;
      control.dt = in.number();
      control.u.resize(p.motion->control_dim());
      for (Eigen::Index i = 0; i < control.u.size(); ++i) control.u(i) = in.number();
      dataset.events.emplace_back(control);
    } else {
      RangeScanEvent scan;
      scan.t = t;
      if (tag & 4) scan.sensor_offset = Pose2(in.number(), in.number(), in.number());
      scan.angle_min = tag & 8 ? in.number() : -kPi / 2;
      scan.angle_increment = tag & 16 ? in.number() : kPi / 16;
      scan.max_range = tag & 32 ? in.number() : 8.0;
      for (int beams = 1 << (2 * (tag >> 6 & 3)); beams > 0; --beams)
        scan.ranges.push_back(static_cast<float>(in.number()));
      dataset.events.emplace_back(std::move(scan));
    }
  }
  refusing_only_with_input_error([&] {
    const auto filter = make_filter(config, dataset);
    check_filter_fits(*filter, dataset);
    run_filter(*filter, dataset);
    if (!filter->pose().allFinite())
      throw std::logic_error("the grid filter's pose is not finite after a run the runner accepted");
  });
}

constexpr FuzzTarget kTargets[] = {
    {"sim_log", sim_log},
    {"course_log", course_log},
    {"mrclam", mrclam},
    {"victoria_park", victoria_park},
    {"carmen", carmen},
    {"world", world},
    {"trajectory", trajectory},
    {"json_settings", json_settings},
    {"run_folder", run_folder},
    {"text", text},
    {"filter_pipeline", filter_pipeline},
    {"grid_pipeline", grid_pipeline},
};

}  // namespace

std::span<const FuzzTarget> targets() { return kTargets; }

const FuzzTarget& target(std::string_view name) {
  for (const FuzzTarget& t : kTargets)
    if (name == t.name) return t;
  std::string names;
  for (const FuzzTarget& t : kTargets) names += std::string(names.empty() ? "" : ", ") + t.name;
  throw std::invalid_argument("no fuzz target '" + std::string(name) + "'; there are: " + names);
}

}  // namespace slamkit::fuzz
