// The policy compiler's entry point: source text in, verified image out.
#ifndef CONTEGO_POLICY_COMPILE_H_
#define CONTEGO_POLICY_COMPILE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "image/image_model.h"

namespace contego::policy {

struct Diagnostic {
  std::string id;        // stable id, e.g. "E0103"
  std::string severity;  // "error" | "warning" | "note"
  std::string file;
  uint32_t line = 0;     // 1-based
  uint32_t column = 0;   // 1-based
  std::string message;
  std::string rendered;  // file:line:col: severity[ID]: message + source line + caret
};

struct CompileOptions {
  bool strict = false;  // warnings are errors
};

struct CompileOutput {
  bool ok = false;                       // no errors (and, if strict, no warnings)
  std::vector<Diagnostic> diagnostics;   // all of them, in source order
  image::ImageModel model;               // valid when ok
  std::vector<uint8_t> image;            // serialised and accepted by core::Checker::load
  uint32_t worst_case_cost = 0;          // bytecode instructions of one check, from the verifier
};

CompileOutput compile_source(const std::string& file_name, const std::string& text,
                             const CompileOptions& options = {});
CompileOutput compile_file(const std::string& path, const CompileOptions& options = {});

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_COMPILE_H_
