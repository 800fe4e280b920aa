#pragma once

// LZF decompression, as PCD's `DATA binary_compressed` stores its fields (library
// mmba_io_cloud). The format is Marc Lehmann's liblzf (lzf_d.c; the same one PCL's
// pcl::lzfDecompress reads): a sequence of chunks, each starting with a control byte c:
//   c < 32            a literal run: the next c + 1 bytes are copied as they are;
//   c >> 5 in 1..6    a back reference of length (c >> 5) + 2;
//   c >> 5 == 7       a back reference of length 7 + next byte + 2;
// a back reference's offset is ((c & 0x1f) << 8) + next byte + 1 bytes back from the end of
// the output written so far (the copy may overlap itself: a run of one repeated pattern).

#include <cstddef>
#include <cstdint>

namespace mmba::io {

/// Why LzfDecompress stopped short.
enum class LzfProblem {
  kNone,              ///< decoded exactly out_size bytes from exactly in_size bytes
  kTruncatedInput,    ///< a chunk runs past the end of the input (a cut-off block)
  kOutputOverflow,    ///< the data decode to more than out_size bytes
  kBadBackReference,  ///< an offset before the start of the output
  kShortOutput,       ///< the input ended before out_size bytes were written
};

/// A readable name of `problem` for messages ("a chunk runs past the end of the data", …).
const char* LzfProblemText(LzfProblem problem);

/// Decodes `in_size` bytes of LZF data into exactly `out_size` bytes at `out`. Returns kNone
/// on success; otherwise the problem, with `*problem_at` (if given) the input offset of the
/// chunk that could not be decoded.
LzfProblem LzfDecompress(const uint8_t* in, size_t in_size, uint8_t* out, size_t out_size,
                         size_t* problem_at = nullptr);

}  // namespace mmba::io
