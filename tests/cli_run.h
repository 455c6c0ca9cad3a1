#pragma once
// Running the gpisvdb program from tests: exit code, stdout and stderr; scratch files; partial-output checks.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
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
    // In a subshell: the redirections apply to the whole command, a pipeline's last stage included (appended to a
    // bare pipeline, "</dev/null" would replace that stage's input, the pipe).
    const int status = std::system(("( " + command + " ) >" + out + " 2>" + err + " </dev/null").c_str());
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
        const bool replaced = std::any_of(
            env.begin(), env.end(), [&](const std::string& v) { return var.compare(0, v.find('=') + 1, v, 0, v.find('=') + 1) == 0; });
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

/// gpisvdb with these arguments (a shell's words; not --quiet), sent SIGINT (as by Ctrl-C) once it reports progress
/// (GPISVDB_PROGRESS=lines), not after a fixed delay: on a loaded machine, under a sanitizer, start-up alone can
/// outlast one, and a signal before main() installs its handlers ends the program without a word. Its exit code
/// (128 + the signal if the signal ended it; -1 if it reported no progress within `limitSeconds` or outlived the signal
/// by 60 s, then killed) and its stderr without the progress lines.
inline Run runInterrupted(const std::string& args, double limitSeconds = 300) {
    const std::string errPath = (gpisvdb::test::scratchDir() / "gpisvdb_cli_interrupted_stderr").string();
    fs::remove(errPath);  // a previous run's progress must not be read as this one's (the child truncates it only later)
    const pid_t pid = spawn({"/bin/sh", "-c", "exec " + std::string(GPISVDB_EXE) + " " + args}, errPath, {"GPISVDB_PROGRESS=lines"});
    Run r;
    if (pid <= 0) return r;
    int status = 0;
    // Waits up to `limit` seconds for the program to end (true) or for `until` to hold (false).
    const auto waitFor = [&](double limit, auto until) {
        for (const auto start = std::chrono::steady_clock::now();
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < limit && !until();
             std::this_thread::sleep_for(std::chrono::milliseconds(20)))
            if (waitpid(pid, &status, WNOHANG) == pid) return true;
        return false;
    };
    const auto progressed = [&] { return fileText(errPath).find("gpisvdb-progress ") != std::string::npos; };
    bool ended = waitFor(limitSeconds, progressed);
    if (!ended && progressed()) {
        kill(pid, SIGINT);
        ended = waitFor(60, [] { return false; });
    }
    if (!ended) kill(pid, SIGKILL), waitpid(pid, &status, 0);
    r.code = !ended ? -1 : WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
    std::istringstream in(fileText(errPath));
    for (std::string line; std::getline(in, line);)
        if (line.rfind("gpisvdb-progress ", 0) != 0) r.err += line + "\n";
    return r;
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
