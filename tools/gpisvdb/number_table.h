#pragma once
// Rows of numbers from a text file: query points, rays. Commas or whitespace separate the numbers; '#' starts a
// comment; blank lines are skipped.
#include <string>
#include <vector>

namespace gpisvdb::cli {

/// Every row of `path`, each of `columns` finite numbers (with `extraIgnored`, words after them are ignored, as
/// the normals of an .xyz cloud given as points). `what` names the rows in messages ("query points") and
/// `layout` the expected row ("x y z"). Throws InputError naming the file and line on a missing file, a row of
/// another length, a value that is not a finite number, or no rows at all.
std::vector<std::vector<double>> readNumberRows(const std::string& path, std::size_t columns, const std::string& what,
                                                const std::string& layout, bool extraIgnored = false);

}  // namespace gpisvdb::cli
