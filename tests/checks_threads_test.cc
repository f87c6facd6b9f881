// RepairOptions::threads bounds every parallel part of the checks
// (validation and the edge and face sorts, with and without reorienting):
// with one thread, TBB starts no worker thread. The test observes the process's
// threads (/proc/self/task), so it must be the first TBB work of its
// process: this binary holds this test alone.
#include <gtest/gtest.h>

#include <filesystem>
#include <iterator>
#include <thread>

#include "lib/core/mesh_repair.h"
#include "lib/core/shapes.h"

namespace meshgauge {
namespace {

int64_t ProcessThreads() {
  const std::filesystem::directory_iterator tasks("/proc/self/task");
  return std::distance(begin(tasks), end(tasks));
}

TEST(ChecksThreadsTest, OneThreadStartsNoWorkerAndTwoDo) {
  if (!std::filesystem::exists("/proc/self/task")) {
    GTEST_SKIP() << "no /proc/self/task";
  }
  // 200,000 faces: validation splits them into four blocks.
  const Mesh torus = MakeTorus(1.0, 0.3, 400, 250);
  const int64_t before = ProcessThreads();
  for (bool reorient : {false, true}) {
    auto one = RepairAndDiagnose(torus, {.reorient = reorient, .threads = 1});
    ASSERT_TRUE(one.ok()) << one.status();
    EXPECT_EQ(one->diagnostics.components, 1);
  }
  EXPECT_EQ(ProcessThreads(), before)
      << "the checks started threads with RepairOptions::threads = 1";
  // The same checks with two threads do start a worker: the count above
  // can see one.
  if (std::thread::hardware_concurrency() < 2) {
    GTEST_SKIP() << "one core: TBB starts no worker for two threads";
  }
  auto two = RepairAndDiagnose(torus, {.reorient = true, .threads = 2});
  ASSERT_TRUE(two.ok()) << two.status();
  EXPECT_GT(ProcessThreads(), before);
}

}  // namespace
}  // namespace meshgauge
