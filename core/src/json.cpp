#include "paintlab/core/json.h"

#include <cerrno>
#include <fcntl.h>
#include <unistd.h>

#include "paintlab/core/atomic_file.h"

namespace fs = std::filesystem;

namespace paintlab {

Json read_json_file(const fs::path& path) {
  std::string text = read_file(path);
  try {
    return Json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw DataError(path.string() + ": not valid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const nlohmann::json::exception& e) {  // a number out of range (1e400)
    throw DataError(path.string() + ": not valid JSON: " + e.what());
  }
}

void write_json_file(const fs::path& path, const Json& value) {
  write_file_atomic(path, value.dump(2) + "\n");
}

std::vector<Json> read_jsonl_file(const fs::path& path, bool* torn_tail) {
  if (torn_tail) *torn_tail = false;
  std::string text = read_file(path);
  std::vector<Json> out;
  std::size_t pos = 0;
  int line_no = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    bool last_without_newline = nl == std::string::npos;
    std::string line = text.substr(pos, last_without_newline ? std::string::npos : nl - pos);
    pos = last_without_newline ? text.size() : nl + 1;
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      out.push_back(Json::parse(line));
    } catch (const nlohmann::json::exception& e) {  // parse_error, or a number out of range (1e400)
      if (last_without_newline) {
        if (torn_tail) *torn_tail = true;
        break;
      }
      throw DataError(path.string() + ":" + std::to_string(line_no) + ": not valid JSON: " + e.what());
    }
    if (last_without_newline && torn_tail) *torn_tail = true;  // complete but unterminated: still torn
  }
  return out;
}

void append_jsonl_line(const fs::path& path, const Json& value) {
  std::string line = value.dump() + "\n";
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError(path.string(), "cannot open for appending", errno, IoOp::Write);
  const char* p = line.data();
  std::size_t n = line.size();
  while (n > 0) {
    ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      int err = errno;
      ::close(fd);
      throw IoError(path.string(), "append failed", err, IoOp::Write);
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  if (::fsync(fd) != 0) {
    int err = errno;
    ::close(fd);
    throw IoError(path.string(), "fsync failed", err, IoOp::Write);
  }
  ::close(fd);
}

Json matrix_to_json(const Eigen::MatrixXd& m) {
  Json rows = Json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    Json row = Json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

Eigen::MatrixXd matrix_from_json(const Json& j, std::string_view what) {
  if (!j.is_array() || j.empty() || !j[0].is_array())
    throw DataError(std::string(what) + ": expected a matrix (array of rows)");
  Eigen::MatrixXd m(j.size(), j[0].size());
  for (std::size_t r = 0; r < j.size(); ++r) {
    if (!j[r].is_array() || j[r].size() != j[0].size())
      throw DataError(std::string(what) + ": row " + std::to_string(r) + " has the wrong length");
    for (std::size_t c = 0; c < j[r].size(); ++c) {
      if (!j[r][c].is_number()) throw DataError(std::string(what) + ": element is not a number");
      m(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = j[r][c].get<double>();
    }
  }
  return m;
}

Json vector3_to_json(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

Eigen::Vector3d vector3_from_json(const Json& j, std::string_view what) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    throw DataError(std::string(what) + ": expected an array of 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

}  // namespace paintlab
