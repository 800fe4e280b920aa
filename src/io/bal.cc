#include "mmba/io/bal.h"

#include <cctype>
#include <limits>
#include <string_view>

#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

// Whitespace tokens with their line numbers (BAL does not fix the line layout of the
// parameter blocks: files put one value per line or a whole block on one line).
class TokenStream {
 public:
  TokenStream(std::string path, const std::string& text) : path_(std::move(path)), text_(text) {}

  /// Next token; throws "truncated" naming `field` at the end.
  std::string_view Next(const std::string& field, const std::string& expected) {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= text_.size()) {
      throw InputError(path_, line_, field, "end of file", expected + " (file truncated?)");
    }
    const size_t start = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    token_line_ = line_;
    return std::string_view(text_).substr(start, pos_ - start);
  }

  double Double(const std::string& field) {
    const std::string_view token = Next(field, "a finite number");
    double v = 0.0;
    if (!ParseDouble(token, &v)) {
      throw InputError(path_, token_line_, field, std::string(token), "a finite number");
    }
    return v;
  }

  /// `first_of_file`: a token that is not a number is not quoted back (the file is then not
  /// a BAL problem at all, and may be any file).
  int64_t Int(const std::string& field, int64_t min, int64_t max, const std::string& expected,
              bool first_of_file = false) {
    const std::string_view token = Next(field, expected);
    int64_t v = 0;
    const bool number = ParseInt(token, &v);
    if (!number && first_of_file) {
      throw InputError(path_, token_line_, field, "a word that is not a number", expected + " (not a BAL file?)");
    }
    if (!number || v < min || v > max) {
      throw InputError(path_, token_line_, field, std::string(token), expected);
    }
    return v;
  }

  void ExpectEnd() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ < text_.size()) {
      const size_t end = text_.find_first_of(" \t\r\n", pos_);
      throw InputError(path_, line_, "end of file",
                       text_.substr(pos_, end == std::string::npos ? 20 : end - pos_),
                       "nothing after the last point (counts in the header too small?)");
    }
  }

 private:
  std::string path_;
  const std::string& text_;
  size_t pos_ = 0;
  int64_t line_ = 1;
  int64_t token_line_ = 1;
};

}  // namespace

BalProblem ReadBal(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  TokenStream in(path, text);
  BalProblem problem;
  constexpr int64_t kMaxCount = std::numeric_limits<int>::max();
  problem.num_cameras = static_cast<int>(
      in.Int("num_cameras", 1, kMaxCount, "a positive integer", /*first_of_file=*/true));
  problem.num_points = static_cast<int>(
      in.Int("num_points", 1, kMaxCount, "a positive integer"));
  const int64_t num_observations =
      in.Int("num_observations", 1, kMaxCount, "a positive integer");
  // A count larger than the file can hold is a wrong header, not a reason to allocate.
  const uint64_t max_tokens = text.size() / 2 + 1;
  if (static_cast<uint64_t>(num_observations) * 4 + problem.num_cameras * 9ull +
          problem.num_points * 3ull > max_tokens) {
    throw InputError(path, 1, "header counts",
                     std::to_string(problem.num_cameras) + " cameras, " +
                         std::to_string(problem.num_points) + " points, " +
                         std::to_string(num_observations) + " observations",
                     "counts that fit the file's " + std::to_string(text.size()) + " bytes");
  }
  problem.observations.resize(num_observations);
  const std::string camera_range =
      "a camera index in [0, " + std::to_string(problem.num_cameras) + ")";
  const std::string point_range =
      "a point index in [0, " + std::to_string(problem.num_points) + ")";
  for (int64_t i = 0; i < num_observations; ++i) {
    BalObservation& obs = problem.observations[i];
    const std::string name = "observation[" + std::to_string(i) + "]";
    obs.camera_index = static_cast<int>(
        in.Int(name + ".camera_index", 0, problem.num_cameras - 1, camera_range));
    obs.point_index = static_cast<int>(
        in.Int(name + ".point_index", 0, problem.num_points - 1, point_range));
    obs.x = in.Double(name + ".x");
    obs.y = in.Double(name + ".y");
  }
  problem.cameras.resize(9 * static_cast<size_t>(problem.num_cameras));
  for (int i = 0; i < problem.num_cameras; ++i) {
    for (int k = 0; k < 9; ++k) {
      problem.cameras[9 * i + k] =
          in.Double("camera[" + std::to_string(i) + "][" + std::to_string(k) + "]");
    }
  }
  problem.points.resize(3 * static_cast<size_t>(problem.num_points));
  for (int i = 0; i < problem.num_points; ++i) {
    for (int k = 0; k < 3; ++k) {
      problem.points[3 * i + k] =
          in.Double("point[" + std::to_string(i) + "][" + std::to_string(k) + "]");
    }
  }
  in.ExpectEnd();
  return problem;
}

}  // namespace mmba::io
