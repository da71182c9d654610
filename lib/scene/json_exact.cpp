#include "lib/scene/json_exact.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <unistd.h>

#include "lib/scene/float_text.h"

namespace visgate {

namespace {

using json = nlohmann::json;

class ExactSax : public nlohmann::json_sax<json> {
 public:
  json root;
  std::string error;
  size_t depth_limit = 256;

  bool null() override { return put(json(nullptr)); }
  bool boolean(bool b) override { return put(json(b)); }
  bool number_integer(number_integer_t v) override { return put(json(v)); }
  bool number_unsigned(number_unsigned_t v) override { return put(json(v)); }
  bool number_float(number_float_t, const string_t& s) override {
    auto f = parse_float(s);
    return put(json(double(f ? *f : 0.0f)));
  }
  bool string(string_t& s) override { return put(json(s)); }
  bool binary(binary_t&) override { return put(json(nullptr)); }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool key(string_t& k) override { key_ = k; return true; }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_array() override { return close(); }
  bool parse_error(std::size_t pos, const std::string&, const nlohmann::detail::exception& ex) override {
    std::string what = ex.what();
    auto p = what.find("syntax error");
    error = "JSON parse error at byte " + std::to_string(pos) + ": " + (p == std::string::npos ? what : what.substr(p));
    return false;
  }

 private:
  std::vector<json*> stack_;
  std::string key_;

  json* insert(json v) {
    if (stack_.empty()) { root = std::move(v); return &root; }
    json* top = stack_.back();
    if (top->is_array()) { top->push_back(std::move(v)); return &top->back(); }
    (*top)[key_] = std::move(v);
    return &(*top)[key_];
  }
  bool put(json v) { insert(std::move(v)); return true; }
  bool open(json v) {
    if (stack_.size() >= depth_limit) { error = "JSON nesting deeper than 256"; return false; }
    stack_.push_back(insert(std::move(v)));
    return true;
  }
  bool close() { stack_.pop_back(); return true; }
};

}  // namespace

Result<nlohmann::json> parse_json_exact(const std::string& text, const std::string& origin) {
  ExactSax sax;
  bool ok = false;
  try {
    ok = json::sax_parse(text, &sax, nlohmann::json::input_format_t::json, true);
  } catch (const std::exception& e) {
    return Error{origin + ": JSON parse error: " + e.what()};
  }
  if (!ok) return Error{origin + ": " + (sax.error.empty() ? std::string("JSON parse error") : sax.error)};
  return std::move(sax.root);
}

Result<std::string> read_text_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return Error{path + ": is a directory"};
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot open file"};
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return Error{path + ": read error"};
  return ss.str();
}

Status write_file_atomic(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  fs::path target(path);
  fs::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return Error{path + ": folder does not exist"};
  fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Error{path + ": cannot write (temporary file " + tmp.string() + ")"};
    out.write(text.data(), std::streamsize(text.size()));
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      return Error{path + ": write failed"};
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Error{path + ": cannot rename temporary file into place"};
  }
  return {};
}

}  // namespace visgate
