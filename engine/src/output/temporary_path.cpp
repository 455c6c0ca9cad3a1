#include "gpisvdb/output/temporary_path.h"

#include <filesystem>
#include <random>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

std::string temporaryPathBeside(const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path target(path);
    std::error_code ec;
    if (fs::is_directory(target, ec)) throw OutputError(path + ": is a directory, expected a file name");
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    if (!fs::is_directory(dir, ec)) throw OutputError(path + ": the directory " + dir.string() + " does not exist");
    std::random_device rd;
    return (dir / (target.filename().string() + ".tmp-" + std::to_string(rd() % 1000000))).string();
}

}  // namespace gpisvdb
