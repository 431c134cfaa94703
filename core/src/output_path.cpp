#include "paintlab/core/output_path.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab {

namespace {

// "a/b/" -> "a/b" (the root stays the root).
fs::path output_path_without_trailing_separator(fs::path p) {
  while (!p.empty() && !p.has_filename() && p.has_relative_path()) p = p.parent_path();
  return p;
}

// The path made absolute and normalised without touching the file system (symlinks kept).
fs::path output_lexical_absolute(const fs::path& p) {
  std::error_code ec;
  const fs::path abs = fs::absolute(p.empty() ? fs::path(".") : p, ec);
  return output_path_without_trailing_separator((ec ? p : abs).lexically_normal());
}

// The folder a file `p` (as typed) goes in: its parent, or "." for a bare name.
fs::path output_parent_or_dot(const fs::path& p) {
  const fs::path parent = output_path_without_trailing_separator(p).parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

std::string output_subject(const OutputSpec& out) {
  if (out.beside.empty()) return out.flag + " " + out.path.string();
  return out.flag + " " + out.beside.string() + " also writes " + out.path.string() + ", which";
}

// "--out X" or "--out B" with the file it is about, for messages about the folder.
std::string output_folder_subject(const OutputSpec& out) {
  return out.flag + " " + (out.beside.empty() ? out.path : out.beside).string();
}

std::string output_input_named(const InputSpec& in) {
  if (!in.flag.empty() && in.flag.front() == '-') return "the input " + in.flag + " " + in.path.string();
  if (in.flag.find(' ') != std::string::npos) return "the input " + in.path.string() + " (" + in.flag + ")";
  return "the input " + in.path.string();
}

// Whether `a` and `b` name one file: the same inode when both exist, else the same resolved path.
bool output_same_file_or_path(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return resolved_output_path(a) == resolved_output_path(b);
}

[[noreturn]] void output_refuse(const std::string& message) { throw UsageError(message); }

void check_output_folder(const OutputSpec& out) {
  std::error_code ec;
  const fs::file_status st = fs::status(out.path, ec);
  if (!out.folder && fs::is_directory(st))
    output_refuse(output_subject(out) + " is a folder; give the name of a file to write");
  if (out.folder && fs::exists(st) && !fs::is_directory(st))
    output_refuse(output_subject(out) + " is a file, not a folder");
  fs::path dir = out.folder && fs::is_directory(st) ? out.path : output_parent_or_dot(out.path);
  const std::string about = out.beside.empty() ? std::string() : " (for " + out.path.string() + ")";
  if (!out.create_parents) {
    const fs::file_status ds = fs::status(dir, ec);
    if (!fs::exists(ds))
      output_refuse(output_folder_subject(out) + ": the folder " + dir.string() + about +
                    " does not exist (create it first)");
    if (!fs::is_directory(ds)) output_refuse(output_folder_subject(out) + ": " + dir.string() + " is not a folder");
  } else {
    // The nearest folder that exists: the missing ones are created in it.
    while (!fs::exists(dir, ec)) {
      const fs::path up = output_parent_or_dot(dir);
      if (up == dir) break;
      dir = up;
    }
    if (!fs::is_directory(dir, ec))
      output_refuse(output_folder_subject(out) + ": " + dir.string() + " is not a folder, so " + out.path.string() +
                    " cannot be created");
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    // Not a wrong command line but a folder the job cannot write into (read-only, no
    // permission): the job fails (exit 1), with the system's reason.
    const int err = errno;
    throw IoError(output_folder_subject(out), "the folder " + dir.string() + about + " is not writable", err,
                  IoOp::Write);
  }
}

}  // namespace

fs::path resolved_output_path(const fs::path& path) {
  std::error_code ec;
  const fs::path p = output_path_without_trailing_separator(path.empty() ? fs::path(".") : path);
  if (fs::exists(p, ec)) {
    fs::path c = fs::canonical(p, ec);
    if (!ec) return c;
  }
  const fs::path abs = output_lexical_absolute(p);
  if (!abs.has_filename() || !abs.has_relative_path()) return abs;
  fs::path parent = fs::weakly_canonical(abs.parent_path(), ec);
  if (ec) parent = abs.parent_path();
  return output_path_without_trailing_separator(parent.lexically_normal()) / abs.filename();
}

bool path_is_within(const fs::path& path, const fs::path& dir) {
  const fs::path p = output_path_without_trailing_separator(path.lexically_normal());
  const fs::path d = output_path_without_trailing_separator(dir.lexically_normal());
  auto pi = p.begin();
  for (auto di = d.begin(); di != d.end(); ++di, ++pi) {
    if (pi == p.end() || *pi != *di) return false;
  }
  return true;
}

void check_output(const OutputSpec& out, std::span<const InputSpec> inputs,
                  std::span<const ProtectedDir> protected_dirs) {
  const fs::path target = resolved_output_path(out.path);
  const fs::path lexical = output_lexical_absolute(out.path);
  for (const InputSpec& in : inputs) {
    if (in.path.empty()) continue;
    if (output_same_file_or_path(out.path, in.path)) {
      if (output_lexical_absolute(in.path) == lexical)
        output_refuse(output_subject(out) + " is " + output_input_named(in) + "; choose another file name");
      output_refuse(output_subject(out) + " is the same file as " + output_input_named(in) +
                    " (through a symlink or hard link); choose another file name");
    }
    if (out.folder && (path_is_within(resolved_output_path(in.path), target) ||
                       path_is_within(output_lexical_absolute(in.path), lexical)))
      output_refuse(output_subject(out) + " holds " + output_input_named(in) + "; choose another folder");
  }
  for (const ProtectedDir& pd : protected_dirs) {
    const fs::path dir = resolved_output_path(pd.path);
    const fs::path dir_lexical = output_lexical_absolute(pd.path);
    if (!path_is_within(target, dir) && !path_is_within(lexical, dir_lexical)) continue;
    const bool is_it = target == dir || lexical == dir_lexical;
    output_refuse(output_subject(out) + (is_it ? " is the " : " is inside the ") + pd.what + " " + pd.path.string() +
                  (pd.why.empty() ? std::string() : " (" + pd.why + ")"));
  }
  check_output_folder(out);
}

void check_outputs_distinct(std::span<const OutputSpec> outputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      if (outputs[i].path.empty() || outputs[j].path.empty()) continue;
      if (output_same_file_or_path(outputs[i].path, outputs[j].path))
        output_refuse(output_subject(outputs[i]) + " is the same file as " + outputs[j].flag + " " +
                      outputs[j].path.string() + "; give each output its own file");
    }
}

std::vector<ProtectedDir> protected_ancestors(
    const fs::path& path, const std::function<std::optional<ProtectedDir>(const fs::path& dir)>& classify) {
  std::vector<ProtectedDir> found;
  std::vector<fs::path> seen;
  auto visit = [&](const fs::path& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return;
    const fs::path key = fs::canonical(dir, ec);
    if (ec || std::find(seen.begin(), seen.end(), key) != seen.end()) return;
    seen.push_back(key);
    if (std::optional<ProtectedDir> p = classify(dir)) found.push_back(std::move(*p));
  };
  // As typed first (messages then name the folder as the user wrote it), then resolved.
  for (fs::path p = output_path_without_trailing_separator(path); !p.empty();) {
    visit(p);
    const fs::path up = p.parent_path();
    if (up == p) break;
    p = up;
  }
  for (fs::path p = resolved_output_path(path);;) {
    visit(p);
    const fs::path up = p.parent_path();
    if (up == p || up.empty()) break;
    p = up;
  }
  return found;
}

}  // namespace paintlab
