#include "number_table.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::cli {

std::vector<std::vector<double>> readNumberRows(const std::string& path, std::size_t columns, const std::string& what,
                                                const std::string& layout, bool extraIgnored) {
    std::ifstream in(path);
    if (!in) throw InputError(path + ": cannot open the " + what);
    std::vector<std::vector<double>> rows;
    std::string line;
    for (std::size_t ln = 1; std::getline(in, line); ++ln) {
        if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
        for (char& c : line)
            if (c == ',') c = ' ';
        std::istringstream words(line);
        std::vector<std::string> tokens;
        for (std::string w; words >> w;) tokens.push_back(w);
        if (tokens.empty()) continue;
        if (tokens.size() < columns || (tokens.size() > columns && !extraIgnored))
            throw InputError(path + ":" + std::to_string(ln) + ": expected '" + layout + "'");
        std::vector<double> row(columns);
        for (std::size_t d = 0; d < columns; ++d) {
            char* end = nullptr;
            row[d] = std::strtod(tokens[d].c_str(), &end);
            if (*end != '\0' || end == tokens[d].c_str() || !std::isfinite(row[d]))
                throw InputError(path + ":" + std::to_string(ln) + ": '" + tokens[d] + "' is not a finite number");
        }
        rows.push_back(std::move(row));
    }
    if (rows.empty()) throw InputError(path + ": no " + what);
    return rows;
}

}  // namespace gpisvdb::cli
