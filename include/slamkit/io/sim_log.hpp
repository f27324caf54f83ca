#pragma once
// A simulator run on disk: a directory of plain-text files that load_dataset("sim:DIR") reads back.
//
//   params.json              {"format": "slamkit-sim", "version": 1,
//                             "simulator": <to_json(SimulatorConfig)>, "initial_pose": [x, y, theta],
//                             "world": {"family": NAME, "world_seed": N}}   (world: drawn from a family only)
//   events.txt               the event stream, one event per line, time never decreasing:
//                              control <t> <dt> <speed> <steer>   control applied over (t - dt, t]
//                              obs <t> <id> <range> <bearing>     one observation; id -1 = unknown
//                            Consecutive obs lines with the same t form one scan; a scan taken at the
//                            end of a control comes after that control's line. Each control starts
//                            where the previous one ended (t - dt equals the previous control's t).
//   truth_poses.txt          <t> <x> <y> <theta>           true pose at t
//   truth_landmarks.txt      <id> <x> <y>                  true landmark positions
//   truth_observations.txt   <t> <true_id>                 one line per obs line of events.txt, in the
//                                                          same order (so ids may be withheld from
//                                                          events.txt while the truth keeps them)
//   world.txt                the world simulated, in the format of read_world
//
// Units: seconds, metres, radians. '#' starts a comment. Numbers are written with 12 significant
// digits, far below any noise the files describe and small enough for long runs.
// The truth files are optional: a log without them is a dataset without ground truth.
#include <string>

#include "slamkit/core/dataset.hpp"
#include "slamkit/sim/simulator.hpp"
#include "slamkit/sim/world.hpp"

namespace slamkit {

/// Writes `dataset` (as made by simulate(world, config)) to `dir`, creating it if needed. A scan
/// without observations has no line to go on and is left out, along with its truth entry.
/// Throws InputError if a file cannot be written.
void write_sim_log(const std::string& dir, const Dataset& dataset, const SimulatorConfig& config,
                   const World& world);

/// `dataset` (as made by simulate) as write_sim_log and read_sim_log would give it back, without the
/// files: every number to the 12 digits the log keeps, parsed as the reader parses it, angles wrapped
/// as it wraps them, scans without observations left out and scans of one logged time made one. The
/// simulated datasets opened by name (io/simulated_datasets.hpp) are this, so a campaign's in-memory
/// run and a run on the log that `slamkit simulate` wrote are the same run, to the last bit. It
/// assumes simulate's output (finite values, times in order) rather than checking what the reader
/// checks; std::invalid_argument if the truth's observation ids do not match the scans.
Dataset as_logged(Dataset dataset);

/// Reads a log written by write_sim_log: the events, the motion and observation models and sensor
/// limits the simulator config implies, and whatever truth is present. spec is "sim:DIR", name
/// "sim:" and the directory's last component. Throws InputError naming the file, the line and what
/// was expected on anything malformed or inconsistent.
Dataset read_sim_log(const std::string& dir);

}  // namespace slamkit
