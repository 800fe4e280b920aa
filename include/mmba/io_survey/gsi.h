#pragma once

// Leica GSI field files (GSI-8 and GSI-16, "GSI Online" data words) into a FieldBook.

#include <string>

#include "mmba/survey/field_book.h"

namespace mmba::io {

/// One GSI data word as it is written: positions 1–2 word index (WI), 3–6 information
/// (block number for WI 11; '.', automatic index, input mode, unit for measurements),
/// 7 sign, then 8 (GSI-8) or 16 (GSI-16) data characters, right-aligned.
struct GsiWord {
  int wi = 0;
  std::string info;  ///< positions 3–6
  char unit = '.';   ///< position 6: the unit digit (0–8) or '.'
  char sign = '+';
  std::string data;  ///< the data characters, leading zeros kept
  /// The data without leading zeros (text words: point ids, codes); "0" stays "0".
  std::string Text() const;
  /// True when the data holds '-' fill ("-----"): a value not measured.
  bool Missing() const;
};

/// Converts the digits of an angle word to radians by its unit digit (Leica GSI Online,
/// "Units"): '2' 400 gon, 5 decimals; '3' 360° decimal, 5 decimals; '4' 360° sexagesimal
/// DDD.MMSSs (last digit 0.1"); '5' 6400 mil, 4 decimals. Returns false (with `problem`)
/// on another unit, a non-digit, or minutes/seconds >= 60.
bool GsiAngleRad(const std::string& digits, char unit, double* rad, std::string* problem);

/// Converts the digits of a length word to metres by its unit digit: '0' m (last digit 1 mm),
/// '1' international ft (1/1000 ft), '6' m (1/10 mm), '7' ft (1/10000 ft), '8' m (1/100 mm);
/// '.' (information words such as WI 43) is read as '0' unless the data holds a decimal
/// point, which is then taken as metres. False (with `problem`) otherwise.
bool GsiLengthM(const std::string& digits, char unit, double* metres, std::string* problem);

/// Reads a Leica GSI file. Per line: GSI-16 when it starts with '*', GSI-8 otherwise; lines
/// starting with '!' and empty lines are skipped. Records:
///   - station: a code block WI 41 = 2 or 21 with WI 42 station id and WI 43 instrument height
///     (TPS/MS field programs), or a line with WI 11 and WI 84–86 and/or 88 and no measurement
///     (station coordinates and instrument height); each starts a Setup;
///   - code block WI 41 = 3: WI 42 is the default reflector height that follows;
///   - measurement: WI 11 with any of 21 Hz, 22 V, 31 slope distance, 32 horizontal distance,
///     33 height difference, 51 ppm/prism constant, 87 reflector height, 71–79 remarks;
///     the reflector height is carried over from the set-up's last one when a line has none;
///   - coordinates: WI 11 with 81–83 and no measurement → FieldBook::points.
/// Word indices 11–89 not listed are read and ignored; '-' filled data is "not measured".
/// Throws InputError (file:line, word, value, expectation) on a word index that is not a
/// GSI one, a malformed or truncated word, a unit that does not fit the word, a measurement
/// before any station record, or a file without records.
survey::FieldBook ReadGsi(const std::string& path);
/// Same from text (`file` names it in messages).
survey::FieldBook ParseGsi(const std::string& text, const std::string& file);

/// True when `path` ends in .gsi (any case).
bool IsGsiPath(const std::string& path);

}  // namespace mmba::io
