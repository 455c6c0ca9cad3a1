#pragma once
// Running the gpisvdb program from tests: exit code, stdout and stderr; scratch files; partial-output checks.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "helpers.h"

namespace gpisvdb::test::cli {

namespace fs = std::filesystem;

struct Run {
    int code = -1;
    std::string out, err;
};

/// A file's whole content ("" when it cannot be read).
inline std::string fileText(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// A shell command line, its stdout and stderr captured.
inline Run runShell(const std::string& command) {
    const fs::path dir = gpisvdb::test::scratchDir();
    const std::string out = (dir / "gpisvdb_cli_stdout").string(), err = (dir / "gpisvdb_cli_stderr").string();
    const int status = std::system((command + " >" + out + " 2>" + err + " </dev/null").c_str());
    Run r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = fileText(out);
    r.err = fileText(err);
    return r;
}

/// Starts `words` (an absolute executable path, then its arguments) as a child process with stdin and stdout on
/// /dev/null, stderr into `errPath`, and the environment plus `env` ("NAME=value", replacing the same names); for
/// tests that signal a running program. Returns its pid.
inline pid_t spawn(std::vector<std::string> words, const std::string& errPath, const std::vector<std::string>& env = {}) {
    std::vector<std::string> vars = env;
    for (char** e = environ; *e; ++e) {
        const std::string var(*e);
        const bool replaced = std::any_of(env.begin(), env.end(), [&](const std::string& v) {
            return var.compare(0, v.find('=') + 1, v, 0, v.find('=') + 1) == 0;
        });
        if (!replaced) vars.push_back(var);
    }
    // Both arrays are made before fork: only async-signal-safe calls between fork and exec
    std::vector<char*> argv, envp;
    for (std::string& w : words) argv.push_back(w.data());
    for (std::string& v : vars) envp.push_back(v.data());
    argv.push_back(nullptr);
    envp.push_back(nullptr);
    const pid_t pid = fork();
    if (pid == 0) {
        const int devnull = open("/dev/null", O_RDWR), err = open(errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(devnull, 0), dup2(devnull, 1), dup2(err, 2);
        execve(argv[0], argv.data(), envp.data());
        _exit(127);
    }
    return pid;
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
