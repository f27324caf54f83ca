#include "slamkit/pipeline/stop_signals.hpp"

#include <pthread.h>

#include <array>
#include <csignal>
#include <stdexcept>

namespace slamkit {

namespace {

constexpr std::array<int, 3> kStopSignals = {SIGINT, SIGTERM, SIGHUP};

// Process-wide, as signal dispositions are. The handler reads only these atomics and `handled`,
// which is written before the handlers are installed.
std::atomic<bool> g_stop{false};
std::atomic<int> g_received{0};
std::atomic<bool> g_active{false};
std::array<struct sigaction, kStopSignals.size()> g_previous{};
std::array<bool, kStopSignals.size()> g_handled{};
sigset_t g_unblocked;
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free,
              "a signal handler may only use lock-free atomics");

extern "C" void on_stop_signal(int signal) {
  int none = 0;
  g_received.compare_exchange_strong(none, signal);
  g_stop.store(true);
  struct sigaction fallback {};
  fallback.sa_handler = SIG_DFL;
  for (std::size_t i = 0; i < kStopSignals.size(); ++i)
    if (g_handled[i]) sigaction(kStopSignals[i], &fallback, nullptr);
}

bool ignored(const struct sigaction& action) {
  return (action.sa_flags & SA_SIGINFO) == 0 && action.sa_handler == SIG_IGN;
}

}  // namespace

StopSignals::StopSignals() {
  if (g_active.exchange(true)) throw std::logic_error("StopSignals: one at a time");
  g_stop.store(false);
  g_received.store(0);
  sigset_t blocked, handled;
  pthread_sigmask(SIG_BLOCK, nullptr, &blocked);
  sigemptyset(&handled);
  sigemptyset(&g_unblocked);
  struct sigaction handler {};
  handler.sa_handler = on_stop_signal;
  sigemptyset(&handler.sa_mask);
  handler.sa_flags = SA_RESTART;
  for (std::size_t i = 0; i < kStopSignals.size(); ++i) {
    sigaction(kStopSignals[i], nullptr, &g_previous[i]);
    g_handled[i] = !ignored(g_previous[i]);
    if (!g_handled[i]) continue;
    sigaction(kStopSignals[i], &handler, nullptr);
    sigaddset(&handled, kStopSignals[i]);
    if (sigismember(&blocked, kStopSignals[i]) == 1) sigaddset(&g_unblocked, kStopSignals[i]);
  }
  pthread_sigmask(SIG_UNBLOCK, &handled, nullptr);
}

StopSignals::~StopSignals() {
  pthread_sigmask(SIG_BLOCK, &g_unblocked, nullptr);
  for (std::size_t i = 0; i < kStopSignals.size(); ++i)
    if (g_handled[i]) sigaction(kStopSignals[i], &g_previous[i], nullptr);
  g_active.store(false);
}

const std::atomic<bool>* StopSignals::flag() const { return &g_stop; }

int StopSignals::received() const { return g_received.load(); }

std::string signal_name(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "signal " + std::to_string(signal);
  }
}

}  // namespace slamkit
