// LZF decompression (include/mmba/io_cloud/lzf.h): the chunk format of liblzf's lzf_d.c.

#include "mmba/io_cloud/lzf.h"

#include <algorithm>

namespace mmba::io {

const char* LzfProblemText(LzfProblem problem) {
  switch (problem) {
    case LzfProblem::kNone: return "no problem";
    case LzfProblem::kTruncatedInput: return "a chunk runs past the end of the compressed data";
    case LzfProblem::kOutputOverflow: return "the data decode to more bytes than declared";
    case LzfProblem::kBadBackReference: return "a back reference points before the start of the data";
    case LzfProblem::kShortOutput: return "the data decode to fewer bytes than declared";
  }
  return "unknown";
}

LzfProblem LzfDecompress(const uint8_t* in, size_t in_size, uint8_t* out, size_t out_size,
                         size_t* problem_at) {
  size_t ip = 0, op = 0;
  const auto fail = [&](LzfProblem problem, size_t at) {
    if (problem_at != nullptr) *problem_at = at;
    return problem;
  };
  while (ip < in_size) {
    const size_t chunk = ip;
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const size_t len = ctrl + 1;
      if (len > in_size - ip) return fail(LzfProblem::kTruncatedInput, chunk);
      if (len > out_size - op) return fail(LzfProblem::kOutputOverflow, chunk);
      std::copy(in + ip, in + ip + len, out + op);
      op += len;
      ip += len;
      continue;
    }
    size_t len = ctrl >> 5;  // back reference
    if (len == 7) {
      if (ip >= in_size) return fail(LzfProblem::kTruncatedInput, chunk);
      len += in[ip++];
    }
    if (ip >= in_size) return fail(LzfProblem::kTruncatedInput, chunk);
    const size_t back = ((ctrl & 0x1fu) << 8) + in[ip++] + 1;
    len += 2;
    if (back > op) return fail(LzfProblem::kBadBackReference, chunk);
    if (len > out_size - op) return fail(LzfProblem::kOutputOverflow, chunk);
    for (size_t k = 0; k < len; ++k, ++op) out[op] = out[op - back];  // may overlap
  }
  if (op != out_size) return fail(LzfProblem::kShortOutput, in_size);
  return LzfProblem::kNone;
}

}  // namespace mmba::io
