// What `contego kmod load` says when contego.ko answers CONTEGO_KMOD_LOAD
// with an error (kmod_load_error.cc): the verifier's refusal, a module and
// a contego of different interfaces (which side is out of date), or errno.
#ifndef CONTEGO_CLI_KMOD_LOAD_ERROR_H_
#define CONTEGO_CLI_KMOD_LOAD_ERROR_H_

#include <linux/contego_kmod.h>
#include <string>

namespace contego::cli {

// The message (one line, no newline) for a CONTEGO_KMOD_LOAD that failed
// with `err`; `answered` is the request as the module left it (status,
// section and index from the verifier; on EPROTO, the module's version).
std::string kmod_load_error(int err, const contego_kmod_load& answered);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_KMOD_LOAD_ERROR_H_
