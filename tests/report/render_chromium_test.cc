// Renders the client report.html (sample_report.h: MakeClientReport) in headless Chromium
// (Debian package `chromium`) and checks the screenshot: it exists, has the requested size, is
// not one colour, and shows the CSS (the green and the red χ²-test verdicts, the red caution
// box of too few check points) and the inline SVG (histogram bars) actually drawn; then the DOM
// Chromium built holds every section of the client report.
// Two Chromium starts per test run; a missing Chromium is a failure, not a skip.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mmba/report/adjust_report.h"
#include "sample_report.h"

namespace mmba::report {
namespace {

namespace fs = std::filesystem;

// The Chromium binary: $MMBA_CHROMIUM, else `chromium` or `chromium-browser` on PATH.
std::string FindChromium() {
  if (const char* env = std::getenv("MMBA_CHROMIUM"); env != nullptr && *env != '\0') return env;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    for (const char* name : {"chromium", "chromium-browser"}) {
      const fs::path candidate = fs::path(dir) / name;
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec) && access(candidate.c_str(), X_OK) == 0) {
        return candidate.string();
      }
    }
  }
  return "";
}

std::string ReadTail(const fs::path& path, size_t max_chars) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  return text.size() > max_chars ? text.substr(text.size() - max_chars) : text;
}

// Pixels within `tolerance` (per channel) of the BGR colour.
int CountColour(const cv::Mat& bgr, int b, int g, int r, int tolerance) {
  cv::Mat mask;
  cv::inRange(bgr, cv::Scalar(b - tolerance, g - tolerance, r - tolerance),
              cv::Scalar(b + tolerance, g + tolerance, r + tolerance), mask);
  return cv::countNonZero(mask);
}

TEST(RenderChromium, SampleReportScreenshot) {
  const std::string chromium = FindChromium();
  ASSERT_FALSE(chromium.empty())
      << "Chromium not found (neither $MMBA_CHROMIUM nor chromium/chromium-browser on PATH): "
         "install it with `apt-get install -y chromium` (scripts/packages.d/report.txt); this "
         "test renders report.html and must not be skipped.";

  const fs::path dir = fs::path(MMBA_BINARY_DIR) / "tests" / "report" / "chromium";
  fs::create_directories(dir);
  const fs::path html_path = dir / "sample_report.html";
  const fs::path png_path = dir / "sample_report.png";
  const fs::path log_path = dir / "chromium.log";
  fs::remove(png_path);
  {
    std::ofstream out(html_path, std::ios::binary);
    out << RenderAdjustReportHtml(testing::MakeClientReport());
    ASSERT_TRUE(out.good()) << "cannot write " << html_path;
  }
  // A private profile so that concurrent runs do not share Chromium's lock.
  const fs::path profile = dir / ("profile-" + std::to_string(::getpid()));
  const std::string command = "timeout 120 '" + chromium +
                              "' --headless --no-sandbox --disable-gpu --disable-dev-shm-usage "
                              "--hide-scrollbars --user-data-dir='" + profile.string() +
                              "' --screenshot='" + png_path.string() +
                              "' --window-size=1200,6000 'file://" + html_path.string() + "' > '" +
                              log_path.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  std::error_code ec;
  fs::remove_all(profile, ec);
  ASSERT_EQ(status, 0) << "Chromium failed (status " << status << ", 124·256 = timeout 120 s): "
                       << command << "\n" << ReadTail(log_path, 2000);
  ASSERT_TRUE(fs::exists(png_path)) << "no screenshot written: " << ReadTail(log_path, 2000);

  const cv::Mat image = cv::imread(png_path.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "cannot decode " << png_path;
  EXPECT_EQ(image.cols, 1200);
  EXPECT_EQ(image.rows, 6000);
  // Not one uniform colour.
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(image.reshape(1), &lo, &hi);
  EXPECT_GT(hi - lo, 100.0);
  const int non_white = image.rows * image.cols - CountColour(image, 255, 255, 255, 6);
  EXPECT_GT(non_white, image.rows * image.cols / 100) << "page nearly blank";
  // The CSS applied: the green "PASSED" verdict (#1a7f37) and status badge.
  EXPECT_GT(CountColour(image, 0x37, 0x7f, 0x1a, 12), 200) << "no green verdict in the screenshot";
  // The inline SVG drawn: histogram bars (#4a78b5).
  EXPECT_GT(CountColour(image, 0xb5, 0x78, 0x4a, 12), 2000) << "no histogram bars in the screenshot";
  // The red "FAILED" verdict of the test with the project's σ (#c62828).
  EXPECT_GT(CountColour(image, 0x28, 0x28, 0xc6, 12), 200) << "no red verdict in the screenshot";
  // The caution box of the accuracy block (background #fdecea).
  EXPECT_GT(CountColour(image, 0xea, 0xec, 0xfd, 3), 5000) << "no caution box in the screenshot";

  // The DOM as Chromium parsed it: every client section is there.
  const fs::path dom_path = dir / "sample_report_dom.html";
  const fs::path profile2 = dir / ("profile-dom-" + std::to_string(::getpid()));
  const std::string dump = "timeout 120 '" + chromium +
                           "' --headless --no-sandbox --disable-gpu --disable-dev-shm-usage --user-data-dir='" +
                           profile2.string() + "' --dump-dom 'file://" + html_path.string() + "' > '" +
                           dom_path.string() + "' 2> '" + log_path.string() + "'";
  const int dump_status = std::system(dump.c_str());
  fs::remove_all(profile2, ec);
  ASSERT_EQ(dump_status, 0) << dump << "\n" << ReadTail(log_path, 2000);
  const std::string dom = ReadTail(dom_path, 100000000);
  for (const char* id : {"summary", "accuracy", "points", "relative", "observations", "images", "crs", "settings",
                         "control", "files"}) {
    EXPECT_NE(dom.find("id=\"" + std::string(id) + "\""), std::string::npos) << "no section " << id << " in the DOM";
  }
  EXPECT_NE(dom.find("test, project's"), std::string::npos);
  EXPECT_EQ(dom.find("/home/surveyor"), std::string::npos);
}

}  // namespace
}  // namespace mmba::report
