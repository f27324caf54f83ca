#pragma once
// The signals that ask a run to stop rather than end the process: SIGINT (Ctrl-C), SIGTERM (kill,
// a job scheduler, a shutdown) and SIGHUP (the terminal closed). While a StopSignals lives, the first
// of them sets the flag RunOptions::stop reads, so the run ends after its current event and its
// result, marked partial, can still be written; the handlers then step aside, so a second signal
// ends the process at once. A signal the process ignores (SIGHUP under nohup) stays ignored.
#include <atomic>
#include <string>

namespace slamkit {

class StopSignals {
 public:
  /// Installs the handlers and unblocks the signals: a stop request must reach the run even if the
  /// parent process started slamkit with them blocked (a parent that waits for signals through
  /// signalfd blocks them, and its children inherit the mask). One StopSignals at a time;
  /// std::logic_error otherwise.
  StopSignals();
  /// Restores the handlers and blocks again what was blocked on construction (the mask is the
  /// calling thread's: construct and destroy on one thread).
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  /// For RunOptions::stop.
  const std::atomic<bool>* flag() const;
  /// The signal that asked to stop, or 0.
  int received() const;
};

/// The exit status of a program that stops on `signal` after finishing up: 128 + its number, as a
/// shell reports a process the signal ended (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP).
constexpr int exit_code_for_signal(int signal) { return 128 + signal; }

/// "SIGINT", "SIGTERM", "SIGHUP", or "signal N" for another.
std::string signal_name(int signal);

}  // namespace slamkit
