// Image measurements of a photogrammetric network (targets, tie points) in files whose columns
// the project names (`columns: [id, image, x, y]` in any order), and the image list
// (image id, file name). docs/formats.md, "Image measurements and control".
//
// Pixel convention of the files: x right, y down, origin at the upper-left CORNER of the
// image (DBAT, PhotoModeler, Australis). mmba's convention (COLMAP: the centre of the top-left
// pixel is (0.5, 0.5)) puts the same corner at (0, 0), so the two coincide and the values are
// used as read; a measurement lies in the image when 0 ≤ x ≤ width and 0 ≤ y ≤ height.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mmba::io {

/// Column names of a measurement file: id (point), image, x, y (pixels), optional sx, sy or sxy
/// (σ in pixels, overriding the file's sigma_px); label, skip and _ are ignored. A line has one
/// field per name.
const std::vector<std::string>& MeasurementColumnNames();
/// CheckColumnNames for a measurement file's `columns` (id, image, x, y required).
void CheckMeasurementColumns(const std::vector<std::string>& columns, const std::string& file, int64_t line,
                             const std::string& field);

struct ImageMeasurement {
  std::string point_id;
  std::string image_id;
  Eigen::Vector2d xy_px = Eigen::Vector2d::Zero();     ///< mmba pixels (= the file's, above)
  Eigen::Vector2d sigma_px = Eigen::Vector2d::Ones();  ///< σ of x and y, > 0
  std::string file;                                    ///< where it was read, for messages
  int64_t line = 0;
};

/// One measurement file as the project names it.
struct MeasurementFile {
  std::string file;
  std::vector<std::string> columns;
  double sigma_px = 1.0;  ///< σ of each coordinate unless the file has sx, sy
};

/// Reads a measurement file. InputError (file:line, column, value, expectation) for a line
/// with too few fields, a value that is not a number, a σ ≤ 0, or a point measured twice in one
/// image.
std::vector<ImageMeasurement> ReadImageMeasurements(const MeasurementFile& spec);

/// InputError naming the measurement's file, line, point and image unless
/// 0 ≤ x ≤ width and 0 ≤ y ≤ height (the image size from its camera).
void CheckInsideImage(const ImageMeasurement& m, uint64_t width, uint64_t height);

/// The image list: `image id, file name` per line ('#' comments, comma or blank separated).
/// InputError for a line with other than two fields or an id listed twice.
std::map<std::string, std::string> ReadImageList(const std::string& path);

}  // namespace mmba::io
