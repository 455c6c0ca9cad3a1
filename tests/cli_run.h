#pragma once
// Running the gpisvdb program from tests: exit code, stdout and stderr; scratch files; partial-output checks.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "helpers.h"

namespace gpisvdb::test::cli {

namespace fs = std::filesystem;

struct Run {
    int code = -1;
    std::string out, err;
};

/// A shell command line, its stdout and stderr captured.
inline Run runShell(const std::string& command) {
    const fs::path dir = gpisvdb::test::scratchDir();
    const std::string out = (dir / "gpisvdb_cli_stdout").string(), err = (dir / "gpisvdb_cli_stderr").string();
    const int status = std::system((command + " >" + out + " 2>" + err + " </dev/null").c_str());
    Run r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream o(out), e(err);
    std::stringstream so, se;
    so << o.rdbuf();
    se << e.rdbuf();
    r.out = so.str();
    r.err = se.str();
    return r;
}

/// gpisvdb with these arguments.
inline Run run(const std::string& args) { return runShell(std::string(GPISVDB_EXE) + " " + args); }

inline std::string temp(const std::string& name, const std::string& content = "") {
    const fs::path p = gpisvdb::test::scratchDir() / ("gpisvdb_cli_" + name);
    if (!content.empty()) std::ofstream(p) << content;
    return p.string();
}

inline std::size_t lines(const std::string& s) { return std::size_t(std::count(s.begin(), s.end(), '\n')); }

inline bool leftovers(const std::string& output) {
    const fs::path p(output);
    if (fs::exists(p)) return true;
    for (const auto& e : fs::directory_iterator(p.parent_path()))
        if (e.path().filename().string().rfind(p.filename().string() + ".tmp-", 0) == 0) return true;
    return false;
}

/// The program sent SIGINT (as by Ctrl-C) after `seconds`; its own exit code is kept.
inline Run runInterrupted(const std::string& args, double seconds) {
    return runShell("timeout --preserve-status -s INT " + std::to_string(seconds) + " " + std::string(GPISVDB_EXE) + " " + args);
}

/// A directory output or its temporary sibling (".NAME.tmp-…") exists.
inline bool directoryLeftovers(const std::string& dir) {
    const fs::path p = fs::path(dir).lexically_normal();
    if (fs::exists(p)) return true;
    for (const auto& e : fs::directory_iterator(p.parent_path()))
        if (e.path().filename().string().rfind("." + p.filename().string() + ".tmp-", 0) == 0) return true;
    return false;
}

}  // namespace gpisvdb::test::cli
