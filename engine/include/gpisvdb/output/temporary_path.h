#pragma once
// Outputs are written under a temporary name beside their final path and renamed into place when complete, so
// that an error or an interrupt leaves no file, nor a partial one (docs/guide.md#errors-exit-codes-interrupts).
#include <string>

namespace gpisvdb {

/// A fresh temporary file name in the folder of `path` ("<name>.tmp-<random>"), for a write that is renamed to
/// `path` when complete. Throws OutputError when `path` is a directory or its folder does not exist.
std::string temporaryPathBeside(const std::string& path);

}  // namespace gpisvdb
