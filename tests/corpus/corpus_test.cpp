// The corpus replay suite (DESIGN section 8): every corpus/<method>/<class>/<sha1>.json
// entry whose method is built in is replayed with the method and the exact oracle.
// `fixed` entries must pass (the method answers the exact class), `open` entries must
// still fail; an open entry that passes fails this test with a message asking to switch
// it to fixed. The oracle's class must still be the entry's expected class.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "tools/harness/corpus.h"
#include "tools/harness/sha1.h"

#ifndef VISGATE_CORPUS_DIR
#error "VISGATE_CORPUS_DIR must name the corpus folder"
#endif

namespace visgate::harness {
namespace {

std::vector<std::string> entries() {
  auto all = list_corpus(VISGATE_CORPUS_DIR);
  return all;
}

class CorpusReplay : public testing::TestWithParam<std::string> {};

TEST_P(CorpusReplay, EntryBehavesAsItsStatusSays) {
  auto e = read_corpus_entry(GetParam());
  ASSERT_TRUE(e.ok()) << e.error().message;
  auto r = replay_entry(*e);
  if (!r.registered) GTEST_SKIP() << r.message;
  EXPECT_EQ(r.exact, e->info.expected) << GetParam() << ": the exact oracle's class changed";
  EXPECT_TRUE(r.ok) << r.message;
}

TEST_P(CorpusReplay, EntryIsNamedByItsContentAndClass) {
  namespace fs = std::filesystem;
  auto e = read_corpus_entry(GetParam());
  ASSERT_TRUE(e.ok()) << e.error().message;
  fs::path p(GetParam());
  std::string text;
  {
    std::ifstream f(p, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  EXPECT_EQ(p.stem().string(), sha1_hex(text));
  EXPECT_EQ(p.parent_path().filename().string(), e->info.class_name);
  EXPECT_EQ(p.parent_path().parent_path().filename().string(), e->info.method);
}

std::string test_name(const testing::TestParamInfo<std::string>& info) {
  namespace fs = std::filesystem;
  fs::path p(info.param);
  std::string n = p.parent_path().parent_path().filename().string() + "_" + p.parent_path().filename().string() + "_" +
                  p.stem().string().substr(0, 12);
  for (auto& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Corpus, CorpusReplay, testing::ValuesIn(entries()), test_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(CorpusReplay);

TEST(CorpusReplaySuite, CorpusFolderHoldsOnlyValidClasses) {
  for (const auto& path : entries()) {
    auto e = read_corpus_entry(path);
    ASSERT_TRUE(e.ok()) << e.error().message;
    const auto& cls = corpus_classes();
    EXPECT_NE(std::find(cls.begin(), cls.end(), e->info.class_name), cls.end()) << path;
    EXPECT_TRUE(e->info.status == "open" || e->info.status == "fixed") << path;
  }
}

}  // namespace
}  // namespace visgate::harness
