// base/once.h: the action runs exactly once whatever the threads, and done() says when.
#include "base/once.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace hfrt {
namespace {

TEST(SettledOnce, RunsOnceAcrossThreadsAndEveryCallerSeesItsResult) {
  SettledOnce once;
  std::atomic<int> runs{0};
  int value = 0;  // written by the action, read by every caller after call()
  EXPECT_FALSE(once.done());
  std::vector<std::thread> threads;
  std::atomic<int> wrong{0};
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 1000; ++i) {
        once.call([&] {
          ++runs;
          value = 42;
        });
        if (value != 42) ++wrong;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(runs.load(), 1);
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_TRUE(once.done());
}

TEST(SettledOnce, AnActionThatThrowsLeavesItUnsettled) {
  SettledOnce once;
  EXPECT_THROW(once.call([] { throw std::runtime_error("no"); }), std::runtime_error);
  EXPECT_FALSE(once.done());
  int runs = 0;
  once.call([&] { ++runs; });
  once.call([&] { ++runs; });
  EXPECT_EQ(runs, 1);
  EXPECT_TRUE(once.done());
}

}  // namespace
}  // namespace hfrt
