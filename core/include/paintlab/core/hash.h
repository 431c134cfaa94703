#pragma once
// SHA-256 checksums of files and data (OpenSSL), lower-case hex.
#include <filesystem>
#include <string>
#include <string_view>

namespace paintlab {

std::string sha256_hex(std::string_view bytes);
std::string sha256_file(const std::filesystem::path& path);  // IoError when unreadable

}  // namespace paintlab
