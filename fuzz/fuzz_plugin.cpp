// fuzz_plugin: differential target for your own method in a plugin (DESIGN section 4,
// include/visgate/plugin.h, docs/external-methods.md). The library is named by the
// environment variable VISGATE_FUZZ_PLUGIN (a path); without it every input returns at
// once, so the target can sit in any target list. Each input decodes (lib/scene/byte_decoder.h) to
// a small scene plus the plugin's options (from its descriptor); the plugin solves it
// in-process with visgate's crash guard off (a crash is the sanitizers' to report) and
// every relation is compared with the exact relation oracle. A mismatch (margin >= tau),
// an error status or a malformed answer prints method, options, relation, exact class,
// margin and the hex-float scene, then aborts (fuzz/differential.h).
//   VISGATE_FUZZ_PLUGIN=$PWD/libmy_caster.so build-fuzz/fuzz/fuzz_plugin corpus/fuzz/fuzz_embree
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_plugin", data, size);
}
