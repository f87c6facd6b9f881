// index.html of `meshgauge report` in a real browser: headless Chromium
// (Debian's `chromium`, installed by scripts/install_deps.sh) renders the
// page with no console message, and its screenshot shows the embedded
// pictures (the map's colours and the red thin-region outlines). Skipped,
// saying why, where no Chromium is installed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "lib/core/colormap.h"
#include "lib/io/png_file.h"
#include "tests/cli_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::RunCli;
using testing::SharedMesh;
using testing::Tmp;

// $MESHGAUGE_CHROMIUM, or chromium / chromium-browser / google-chrome on
// PATH; empty when none.
std::string FindChromium() {
  if (const char* env = std::getenv("MESHGAUGE_CHROMIUM")) return env;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    size_t begin = 0;
    while (begin <= dirs.size()) {
      const size_t end = std::min(dirs.find(':', begin), dirs.size());
      const std::filesystem::path candidate =
          std::filesystem::path(dirs.substr(begin, end - begin)) / name;
      if (std::filesystem::exists(candidate)) return candidate.string();
      begin = end + 1;
    }
  }
  return "";
}

TEST(ReportPageTest, RendersInHeadlessChromiumWithNoConsoleMessage) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "no chromium on PATH (scripts/install_deps.sh installs "
                    "Debian's chromium); the page was not opened";
  }
  const std::filesystem::path dir = Tmp("page");
  const auto report = RunCli("report " + SharedMesh("rocker-arm.obj") +
                             " --t-min 0.08 --rays 20 --view-size 300 240 "
                             "--out " +
                             dir.string());
  ASSERT_EQ(report.exit_code, 0) << report.out;
  const std::filesystem::path shot = dir / "screenshot.png";
  const std::filesystem::path log = dir / "chromium.log";
  const std::string cmd =
      chromium +
      " --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir=" +
      (dir / "profile").string() +
      " --window-size=1000,1400 --enable-logging=stderr --v=0 "
      "--screenshot=" +
      shot.string() + " file://" +
      std::filesystem::absolute(dir / "index.html").string() + " >" +
      log.string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(log);
  std::string console;
  for (std::string line; std::getline(in, line);) {
    if (line.find(":CONSOLE") != std::string::npos) console += line + "\n";
  }
  EXPECT_EQ(console, "") << "the page logged to the console";
  auto image = ReadPng(shot.string());
  ASSERT_TRUE(image.ok()) << image.status();
  std::set<uint32_t> colours;
  int outline = 0;
  for (const Rgb& p : image->pixels) {
    colours.insert(p.r << 16 | p.g << 8 | p.b);
    outline += p == kThinOutline;
  }
  EXPECT_GT(colours.size(), 500u) << "a blank or text-only screenshot";
  EXPECT_GT(outline, 50) << "no thin-region outline: the views did not show";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace meshgauge
