// SourceBuffer: one policy file's text, its name as the user gave it, and a
// line table that turns byte offsets into 1-based line:column positions.
// Every later phase refers to source positions by byte offset only.
#ifndef CONTEGO_POLICY_SOURCE_SOURCE_H_
#define CONTEGO_POLICY_SOURCE_SOURCE_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace contego::policy {

// A half-open byte range [begin, end) in one SourceBuffer.
struct Span {
  uint32_t begin = 0;
  uint32_t end = 0;
};

struct LineCol {
  uint32_t line = 1;    // 1-based
  uint32_t column = 1;  // 1-based, in bytes
};

class SourceBuffer {
 public:
  SourceBuffer(std::string file_name, std::string text);

  const std::string& file_name() const { return file_name_; }
  std::string_view text() const { return text_; }
  uint32_t size() const { return static_cast<uint32_t>(text_.size()); }

  // Position of byte `offset` (clamped to the end of the text).
  LineCol position(uint32_t offset) const;
  // The text of 1-based line `line`, without its line terminator.
  std::string_view line_text(uint32_t line) const;
  uint32_t line_count() const { return static_cast<uint32_t>(line_starts_.size()); }

 private:
  std::string file_name_;
  std::string text_;
  std::vector<uint32_t> line_starts_;  // byte offset of each line's first byte
};

// `text` on one line: each run of whitespace becomes one space, none is kept
// at either end; with `drop_comments`, `#` to the end of its line goes too.
std::string one_line(std::string_view text, bool drop_comments = false);

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_SOURCE_SOURCE_H_
