// Small file-system helpers shared by the writers.
#pragma once

#include <string>

namespace wake {

/// Writes `contents` to `path` without ever leaving a half-written file there: writes
/// `path`.tmp, then renames it over `path`. Throws std::runtime_error naming the file.
void writeFileAtomically(const std::string& path, const std::string& contents);

/// Renames `from` to `to` (replacing `to`). Throws std::runtime_error naming both.
void renameFile(const std::string& from, const std::string& to);

/// Forces a file's (or a folder's) contents to disk (fsync). Throws std::runtime_error
/// naming it.
void syncFile(const std::string& path);

/// Wake's version, "MAJOR.MINOR.PATCH" (the CMake project version).
const char* wakeVersion();

}  // namespace wake
