// SIGINT, SIGTERM and SIGHUP ask a run to stop: the first sets the flag the runner reads, and the
// handlers step aside so that a second one ends the process. A signal the process ignores (nohup)
// stays ignored; a blocked one is let through; everything is put back afterwards.
#include "slamkit/pipeline/stop_signals.hpp"

#include <gtest/gtest.h>
#include <pthread.h>

#include <csignal>
#include <stdexcept>

namespace slamkit {
namespace {

void (*disposition(int signal))(int) {
  struct sigaction current {};
  sigaction(signal, nullptr, &current);
  return current.sa_handler;
}

extern "C" void previous_handler(int) {}

TEST(StopSignals, TheFirstSignalAsksToStopAndTheHandlersStepAside) {
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    std::signal(SIGTERM, previous_handler);  // what the destructor must put back
    {
      const StopSignals stop;
      EXPECT_FALSE(stop.flag()->load());
      EXPECT_EQ(stop.received(), 0);
      ASSERT_EQ(std::raise(signal), 0);
      EXPECT_TRUE(stop.flag()->load()) << signal_name(signal);
      EXPECT_EQ(stop.received(), signal);
      for (const int other : {SIGINT, SIGTERM, SIGHUP})
        EXPECT_EQ(disposition(other), SIG_DFL) << "a second " << signal_name(other) << " ends the process";
    }
    EXPECT_EQ(disposition(SIGTERM), previous_handler);
    EXPECT_EQ(disposition(SIGINT), SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
  }
  EXPECT_EQ(exit_code_for_signal(SIGINT), 130);
  EXPECT_EQ(exit_code_for_signal(SIGTERM), 143);
  EXPECT_EQ(exit_code_for_signal(SIGHUP), 129);
  EXPECT_EQ(signal_name(SIGTERM), "SIGTERM");
  EXPECT_EQ(signal_name(SIGUSR1), "signal " + std::to_string(SIGUSR1));
}

// Under nohup SIGHUP is ignored, and a run must then outlive its terminal.
TEST(StopSignals, AnIgnoredSignalStaysIgnored) {
  std::signal(SIGHUP, SIG_IGN);
  {
    const StopSignals stop;
    EXPECT_EQ(disposition(SIGHUP), SIG_IGN);
    ASSERT_EQ(std::raise(SIGHUP), 0);
    EXPECT_FALSE(stop.flag()->load());
  }
  EXPECT_EQ(disposition(SIGHUP), SIG_IGN);
  std::signal(SIGHUP, SIG_DFL);
}

// A parent that blocked SIGTERM (and its children inherit the mask) must not make the run deaf to it:
// a pending one arrives as the handlers are installed, and the mask is as it was afterwards.
TEST(StopSignals, ABlockedSignalIsLetThroughWhileTheRunLasts) {
  sigset_t term;
  sigemptyset(&term);
  sigaddset(&term, SIGTERM);
  ASSERT_EQ(pthread_sigmask(SIG_BLOCK, &term, nullptr), 0);
  ASSERT_EQ(std::raise(SIGTERM), 0);  // pending
  {
    const StopSignals stop;
    EXPECT_TRUE(stop.flag()->load());
    EXPECT_EQ(stop.received(), SIGTERM);
  }
  sigset_t now;
  pthread_sigmask(SIG_BLOCK, nullptr, &now);
  EXPECT_EQ(sigismember(&now, SIGTERM), 1);
  ASSERT_EQ(pthread_sigmask(SIG_UNBLOCK, &term, nullptr), 0);
}

TEST(StopSignals, OneAtATime) {
  const StopSignals first;
  EXPECT_THROW(StopSignals second, std::logic_error);
}

}  // namespace
}  // namespace slamkit
