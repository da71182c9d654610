// visgate repair IN -o OUT [--weld-tolerance T] [--weld-mode=chain|strict] [--report r.json]
//                [--in-place] [--split-nonmanifold] [--fill-holes N] [--stl-ascii]
// visgate repair --check IN [--weld-tolerance T] [--report r.json]
// (DESIGN section 7.) Exit codes: 0 clean after repair (or clean input with
// --check), 1 defects left (listed), 2 bad input or usage (nothing written), 3 internal.
// The input is never modified unless --in-place; files are written through a temporary
// file and a rename. --in-place keeps the file's mode and owner, replaces the target of
// a symbolic link (not the link), and warns that other hard links keep the old content.
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "lib/repair/repair.h"
#include "lib/repair/repair_input.h"
#include "lib/repair/repair_report.h"
#include "lib/repair/sha256.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/mesh_io.h"
#include "lib/repair/cgal_predicates.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {

struct RepairOpts {
  static constexpr const char* kHelp = "Repair and weld a triangle mesh (OBJ, OFF, PLY, STL), with a report";
  std::string in, out, report, weld_mode = "chain";
  double tolerance = 0.0;
  size_t fill_holes = 0;
  bool in_place = false, split = false, check = false, stl_ascii = false;
  void bind(CLI::App* sub) {
    sub->add_option("input", in, "Input mesh")->required();
    sub->add_option("-o,--output", out, "Output mesh (.obj .off .ply .stl)");
    sub->add_option("--weld-tolerance", tolerance, "Merge vertices within this Euclidean distance (default 0: equal positions)");
    sub->add_option("--weld-mode", weld_mode, "chain (merge whole chains) or strict (no cluster wider than T)");
    sub->add_option("--report", report, "Write the JSON report here");
    sub->add_flag("--in-place", in_place, "Overwrite the input file");
    sub->add_flag("--split-nonmanifold", split, "Duplicate non-manifold vertices and edges");
    sub->add_option("--fill-holes", fill_holes, "Fill boundary loops of at most N edges");
    sub->add_flag("--check", check, "Only analyse and report; write no mesh");
    sub->add_flag("--stl-ascii", stl_ascii, "Write ASCII STL instead of binary");
  }
};

// Files written together: each is written to a temporary file next to its target, and
// commit() renames them all into place; until then (and after any failure) the targets
// are untouched and the temporary files are removed.
class StagedFiles {
 public:
  ~StagedFiles() {
    std::error_code ec;
    for (const auto& [tmp, target] : staged_) std::filesystem::remove(tmp, ec);
  }
  // `like`: the file being replaced (--in-place), whose mode and owner the new file takes.
  Status stage(const std::string& target, const std::string& bytes, const struct stat* like = nullptr) {
    namespace fs = std::filesystem;
    fs::path t(target);
    fs::path dir = t.parent_path().empty() ? fs::path(".") : t.parent_path();
    fs::path tmp = dir / ("." + t.filename().string() + ".visgate-tmp" + std::to_string(::getpid()));
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Error{target + ": cannot write (temporary file " + tmp.string() + ")"};
    staged_.push_back({tmp.string(), target});
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.flush();
    if (!out) return Error{target + ": write failed (disk full?)"};
    out.close();
    if (like) {
      // Owner first: chown may clear set-id bits, which chmod then restores.
      if (::chown(tmp.c_str(), like->st_uid, like->st_gid) != 0 && (like->st_uid != ::geteuid()))
        return Error{target + ": cannot keep its owner (uid " + std::to_string(like->st_uid) + ")"};
      if (::chmod(tmp.c_str(), like->st_mode & 07777) != 0) return Error{target + ": cannot keep its mode"};
    }
    return {};
  }
  Status commit() {
    for (size_t i = 0; i < staged_.size(); ++i) {
      std::error_code ec;
      std::filesystem::rename(staged_[i].first, staged_[i].second, ec);
      if (ec) return Error{staged_[i].second + ": cannot rename the temporary file into place"};
      staged_[i].first.clear();
    }
    staged_.clear();
    return {};
  }

 private:
  std::vector<std::pair<std::string, std::string>> staged_;  // temporary file, target
};

// Same file (existing or not), by canonical path.
bool same_path(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

int run_repair(const RepairOpts& o) {
  auto t0 = std::chrono::steady_clock::now();
  mesh::RepairOptions ro;
  ro.weld_tolerance = o.tolerance;
  ro.split_nonmanifold = o.split;
  ro.fill_holes = o.fill_holes;
  ro.check_only = o.check;
  if (o.weld_mode == "chain") ro.weld_mode = mesh::WeldMode::Chain;
  else if (o.weld_mode == "strict") ro.weld_mode = mesh::WeldMode::Strict;
  else return bad_input("--weld-mode " + o.weld_mode + ": expected chain or strict");
  if (!(o.tolerance >= 0.0) || !std::isfinite(o.tolerance))
    return bad_input("--weld-tolerance: must be a finite number >= 0");

  // Usage: where the output goes.
  std::string out = o.out;
  if (o.check) {
    if (!out.empty() || o.in_place) return bad_input("--check writes no mesh: drop -o and --in-place");
  } else {
    if (out.empty() && !o.in_place) return bad_input("repair: give -o OUT (or --in-place to overwrite " + o.in + ")");
    if (o.in_place && out.empty()) out = o.in;
    if (o.in_place && !same_path(out, o.in)) return bad_input("--in-place: -o " + out + " differs from the input " + o.in);
    if (!o.in_place && same_path(out, o.in))
      return bad_input("-o " + out + ": is the input file; refusing to overwrite it without --in-place");
  }
  if (!o.report.empty() && (same_path(o.report, o.in) || (!out.empty() && same_path(o.report, out))))
    return bad_input("--report " + o.report + ": must differ from the input and output meshes");
  mesh::MeshFormat fmt = mesh::MeshFormat::Obj;
  // --in-place on a file without an extension writes the format its content had.
  const bool format_from_content = o.in_place && std::filesystem::path(out).extension().empty();
  if (!o.check) {
    auto f = format_from_content ? Result<mesh::MeshFormat>(mesh::MeshFormat::Obj) : mesh::format_from_path(out, o.stl_ascii);
    if (!f) return bad_input(f.error().message);
    fmt = *f;
    std::error_code ec;
    auto dir = std::filesystem::path(out).parent_path();
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec)) return bad_input(out + ": folder does not exist");
  }
  if (!o.report.empty()) {
    std::error_code ec;
    auto dir = std::filesystem::path(o.report).parent_path();
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec)) return bad_input(o.report + ": folder does not exist");
  }
  // Targets that are folders would fail only at the rename, after the other file moved.
  for (const std::string& target : {o.check ? std::string() : out, o.report}) {
    std::error_code ec;
    if (!target.empty() && std::filesystem::is_directory(target, ec)) return bad_input(target + ": is a folder");
  }

  // Read, then audit what the reader does not keep (attributes, double coordinates).
  auto decoded = decode_mesh_file(o.in);
  if (!decoded) return bad_input(decoded.error().message);
  // The report hashes the file's own bytes, which differ from the decoded ones only
  // when decoding changed them.
  const bool report = !o.report.empty();  // only the JSON report holds the hashes
  Result<std::string> bytes = decoded->changed && report ? read_text_file(o.in) : Result<std::string>(std::string());
  if (!bytes) return bad_input(bytes.error().message);
  auto soup = read_polygon_file(o.in, *decoded);
  if (!soup) return bad_input(soup.error().message);
  if (format_from_content) {
    auto f = mesh::format_from_path("in" + soup->format, o.stl_ascii);
    if (!f) return bad_input(f.error().message);
    fmt = *f;
  }
  auto audit = mesh::audit_input(o.in, decoded->bytes, *soup);
  if (!audit) return bad_input(audit.error().message);
  for (const std::string& w : soup->warnings) std::fprintf(stderr, "warning: %s: %s\n", o.in.c_str(), w.c_str());

  // Repair.
  mesh::CgalExactPredicates ex;
  auto res = mesh::repair_mesh(*soup, ro, ex);
  if (!res) return bad_input(o.in + ": " + res.error().message);
  const mesh::RepairResult& r = *res;

  mesh::ReportContext ctx;
  ctx.input_path = o.in;
  if (report) ctx.input_sha256 = mesh::sha256_hex(decoded->changed ? *bytes : decoded->bytes);
  ctx.options = ro;
  ctx.audit = *audit;
  std::string encoded;
  if (!o.check) {
    auto enc = mesh::encode_mesh(r.output, fmt, out);
    if (!enc) return bad_input(enc.error().message);
    encoded = std::move(*enc);
    ctx.output_path = out;
    if (report) ctx.output_sha256 = mesh::sha256_hex(encoded);
  }
  ctx.exit_code = mesh::remaining_defects(r, o.check).empty() ? kOk : kFound;
  ctx.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Write: the mesh and the report each to a temporary file in its folder, and only when
  // both are complete, rename them into place.
  StagedFiles files;
  if (!o.check) {
    if (o.in_place) {
      // The file itself is replaced, not a symbolic link to it: the new content is
      // renamed onto the link's final target, next to it, with its mode and owner.
      std::error_code ec;
      const std::string target = std::filesystem::canonical(out, ec).string();
      struct stat st_in {};
      if (ec || ::stat(target.c_str(), &st_in) != 0) return bad_input(out + ": cannot resolve the file to replace");
      if (st_in.st_nlink > 1)
        std::fprintf(stderr, "warning: %s: has %lu other hard links, which keep the old content\n", out.c_str(),
                     static_cast<unsigned long>(st_in.st_nlink - 1));
      Status st = files.stage(target, encoded, &st_in);
      if (!st) return bad_input(st.error().message);
    } else {
      Status st = files.stage(out, encoded);
      if (!st) return bad_input(st.error().message);
    }
  }
  if (!o.report.empty()) {
    Status st = files.stage(o.report, mesh::repair_report_json(r, *soup, ctx).dump(2) + "\n");
    if (!st) return bad_input(st.error().message);
  }
  if (Status st = files.commit(); !st) return bad_input(st.error().message);
  std::string table = mesh::repair_report_table(r, *soup, ctx);
  std::fwrite(table.data(), 1, table.size(), stderr);
  return ctx.exit_code;
}

}  // namespace

void add_repair(CLI::App& app, Action& run) {
  add_command<RepairOpts>(app, run, "repair", RepairOpts::kHelp, run_repair);
}

}  // namespace visgate::cli
