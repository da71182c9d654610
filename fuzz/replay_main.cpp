// Plain replay main for the main (g++) build (DESIGN section 9): runs a fuzz target's
// LLVMFuzzerTestOneInput on every file named on the command line and on every regular
// file directly inside every directory named (sorted by name, not recursive; names
// starting with '.' and README/notes files (*.md, *.txt) are skipped). Without libFuzzer
// this keeps every target compiling and lets ctest replay the seed corpora and stored
// cases: a target that aborts or throws fails the test.
//
// `--expect-failure FILE...` replays each file in a child process and succeeds only if
// every one of them still fails (abort, signal or non-zero exit): the check for stored
// open findings (DESIGN section 8). A finding that passes is reported as fixed.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

bool skipped(const std::filesystem::path& p) {
  const std::string name = p.filename().string();
  const std::string ext = p.extension().string();
  return name.empty() || name[0] == '.' || ext == ".md" || ext == ".txt";
}

}  // namespace

std::vector<uint8_t> read_bytes(const std::filesystem::path& p, bool& ok) {
  std::ifstream in(p, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ok = static_cast<bool>(in) || in.eof();
  return bytes;
}

void run_one(const std::vector<uint8_t>& bytes) {
  static const uint8_t empty = 0;  // libFuzzer never passes a null pointer; neither do we
  LLVMFuzzerTestOneInput(bytes.empty() ? &empty : bytes.data(), bytes.size());
}

// Runs each file in a child; 0 when every child failed, 1 when one passed.
int expect_failure(int argc, char** argv) {
  int passed = 0;
  for (int a = 2; a < argc; ++a) {
    bool ok = false;
    auto bytes = read_bytes(argv[a], ok);
    if (!ok) {
      std::fprintf(stderr, "%s: read error\n", argv[a]);
      return 2;
    }
    std::fflush(nullptr);
    pid_t pid = ::fork();
    if (pid < 0) return 2;
    if (pid == 0) {
      run_one(bytes);
      std::fflush(nullptr);
      ::_exit(0);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      std::fprintf(stderr, "%s: open finding now passes: it is fixed; move it into the seed corpus\n", argv[a]);
      ++passed;
    } else {
      std::fprintf(stderr, "%s: still fails, as recorded\n", argv[a]);
    }
  }
  return passed ? 1 : 0;
}

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  if (argc >= 2 && std::string(argv[1]) == "--expect-failure") return expect_failure(argc, argv);
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE|DIR...  (replays inputs through LLVMFuzzerTestOneInput)\n", argv[0]);
    return 2;
  }
  std::vector<fs::path> inputs;
  for (int a = 1; a < argc; ++a) {
    fs::path p(argv[a]);
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      std::vector<fs::path> files;
      for (const auto& e : fs::directory_iterator(p, ec))
        if (e.is_regular_file() && !skipped(e.path())) files.push_back(e.path());
      std::sort(files.begin(), files.end());
      inputs.insert(inputs.end(), files.begin(), files.end());
    } else if (fs::is_regular_file(p, ec)) {
      inputs.push_back(p);
    } else {
      std::fprintf(stderr, "%s: no such file or directory\n", argv[a]);
      return 2;
    }
  }
  for (const auto& p : inputs) {
    bool ok = false;
    auto bytes = read_bytes(p, ok);
    if (!ok) {
      std::fprintf(stderr, "%s: read error\n", p.c_str());
      return 2;
    }
    std::fprintf(stderr, "replay %s (%zu bytes)\n", p.c_str(), bytes.size());
    run_one(bytes);
  }
  std::fprintf(stderr, "replayed %zu inputs\n", inputs.size());
  return 0;
}
