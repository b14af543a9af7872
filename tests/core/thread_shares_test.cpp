#include "core/thread_shares.h"

#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace isoslab {
namespace {

// Every share runs once per run, on as many threads as asked (share 0 on the caller), for runs of
// every size in turn; shares beyond size() run on the caller.
TEST(ThreadShares, EveryShareRunsOnceOnItsThread) {
  ThreadShares pool(3);
  EXPECT_EQ(pool.size(), 3u);
  for (int round = 0; round < 200; ++round) {
    const std::size_t n = static_cast<std::size_t>(round % 6);
    std::vector<int> runs(n, 0);
    std::vector<std::thread::id> on(n);
    pool.run(n, [&](std::size_t i) {
      ++runs[i];
      on[i] = std::this_thread::get_id();
    });
    for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(runs[i], 1) << "share " << i << " of " << n;
    if (n == 0) continue;
    EXPECT_EQ(on[0], std::this_thread::get_id());
    std::set<std::thread::id> threads(on.begin(),
                                      on.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(n, 3)));
    EXPECT_EQ(threads.size(), std::min<std::size_t>(n, 3));
    for (std::size_t i = 3; i < n; ++i) EXPECT_EQ(on[i], std::this_thread::get_id());
  }
}

TEST(ThreadShares, RethrowsTheFirstErrorByShareAndRunsOn) {
  ThreadShares pool(2);
  std::atomic<int> ran{0};
  try {
    pool.run(4, [&](std::size_t i) {
      ++ran;
      if (i >= 1) throw std::runtime_error("share " + std::to_string(i));
    });
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "share 1");
  }
  EXPECT_EQ(ran.load(), 4);
  // The pool still works after an error.
  std::atomic<int> again{0};
  pool.run(2, [&](std::size_t) { ++again; });
  EXPECT_EQ(again.load(), 2);
}

TEST(ThreadShares, OneThreadRunsEverythingHere) {
  ThreadShares pool(0);
  EXPECT_EQ(pool.size(), 1u);
  std::vector<std::size_t> order;
  pool.run(3, [&](std::size_t i) { order.push_back(i); });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2}));
}

}  // namespace
}  // namespace isoslab
