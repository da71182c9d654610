// The regression corpus (DESIGN section 8): entries
// corpus/<method>/<class>/<sha1-of-content>.json, each a self-contained scene (inline
// vertices) plus a `case` object naming the relation, the method, the expected exact
// class, the margin, provenance and the status (`fixed`: the method must answer
// correctly; `open`: a known failure that must still fail, so a silent fix is noticed).
// Writing, classifying, reading and replaying entries.
#pragma once

#include <string>
#include <vector>

#include "lib/solver.h"
#include "tools/harness/minimize.h"

namespace visgate::harness {

// The classes of DESIGN section 8.
const std::vector<std::string>& corpus_classes();

struct CaseInfo {
  std::string method;
  std::map<std::string, std::string> options;
  size_t receiver = 0, light = 0;
  long sample = 0;
  double tau = 1e-5;
  char expected = 'v';     // exact class 'v' or 'b'
  bool method_visible = false;  // the method's answer when stored
  double margin = 0.0;
  std::string direction;   // false-visible or false-blocked
  std::string class_name;  // one of corpus_classes()
  std::string status = "open";  // "open" or "fixed"
  std::string note;
  // Provenance.
  std::string family, source_scene, tool = "visgate 0.1.0";
  uint64_t seed = 0;
  size_t source_receiver = 0, source_light = 0;
  long source_sample = 0;
  size_t source_triangles = 0;
};

// The geometric class of a minimal case (DESIGN section 8): the family's own class for
// torus, pouch, double-surface, far-origin and sliver-soup (sliver); otherwise, from the
// segment and the triangle nearest to changing the answer, in this order: coplanar,
// vertex-on-segment, edge-on-segment, near-endpoint, sliver, other (tolerances relative
// to the scene diagonal, documented in corpus.cpp).
std::string classify_case(const Scene& scene, size_t receiver, size_t light, long sample, const std::string& family);

// The entry text: the scene JSON with a "case" object appended.
std::string corpus_entry_text(const Scene& scene, const CaseInfo& info);
// Writes the entry to <root>/<method>/<class>/<sha1>.json (folders created); returns the
// path. An identical entry already present is left as it is.
Result<std::string> write_corpus_entry(const std::string& root, const Scene& scene, const CaseInfo& info);

struct CorpusEntry {
  std::string path;
  Scene scene;
  CaseInfo info;
};
Result<CorpusEntry> read_corpus_entry(const std::string& path);
// Every *.json under root except root/fuzz/, sorted.
std::vector<std::string> list_corpus(const std::string& root);

struct ReplayResult {
  bool registered = true;   // false: the method is not built in (skipped)
  bool disagrees = false;   // the method's bit disagrees with the exact class (margin >= tau)
  char exact = 'v';         // exact class now
  double margin = 0.0;
  bool ok = false;          // fixed and agrees, or open and still disagrees, and exact == expected
  std::string message;      // why not ok (or the skip reason)
};
ReplayResult replay_entry(const CorpusEntry& e);

}  // namespace visgate::harness
