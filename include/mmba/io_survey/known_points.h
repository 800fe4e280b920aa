#pragma once

#include <string>
#include <vector>

#include "mmba/survey/field_book.h"

namespace mmba::io {

/// Known coordinates for a field book: a Leica GSI file (coordinate records WI 11 + 81–83 and
/// station records WI 84–86) or a CSV of `id,east,north[,height]` in metres (a first line
/// whose east is not a number is a header; '#' starts a comment; an empty height = no
/// height). A point recorded again in a GSI file keeps its first record. Throws InputError
/// (file:line, field, value, expectation) on a malformed line, a point given twice in a CSV,
/// or a file without points.
std::vector<survey::KnownPoint> ReadKnownPoints(const std::string& path);

}  // namespace mmba::io
