#include "headless_display.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>
#include <X11/Xlib.h>

#include <cstdlib>
#include <mutex>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

/// A connection held for the life of the process: an X server resets when its last client leaves, and a
/// connection VTK attempts during that reset fails (VTK then aborts).
Display*& heldConnection() {
    static Display* d = nullptr;
    return d;
}

bool displayAnswers(const char* name) {
    Display* d = XOpenDisplay(name);
    if (!d) return false;
    if (heldConnection()) XCloseDisplay(heldConnection());
    heldConnection() = d;
    return true;
}

/// The Xvfb child; stopped when the process exits.
struct XvfbServer {
    pid_t pid = -1;
    ~XvfbServer() {
        if (pid <= 0) return;
        kill(pid, SIGTERM);
        waitpid(pid, nullptr, 0);
    }
};

XvfbServer& server() {
    static XvfbServer s;
    return s;
}

/// Starts Xvfb on a free display it picks itself (-displayfd) and returns ":N".
std::string startXvfb() {
    int fds[2];
    if (pipe(fds) != 0) throw OutputError("rendering: cannot create a pipe to start Xvfb");
    const pid_t pid = fork();
    if (pid < 0) throw OutputError("rendering: cannot fork to start Xvfb");
    if (pid == 0) {
        // Own process group: a Ctrl-C meant for us must not stop the server while VTK still draws on it.
        setpgid(0, 0);
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        sigset_t none;  // the CLI blocks SIGINT and SIGTERM in all its threads; the server must obey them
        sigemptyset(&none);
        sigprocmask(SIG_SETMASK, &none, nullptr);
        close(fds[0]);
        const int devnull = open("/dev/null", O_RDWR);
        dup2(devnull, STDIN_FILENO);
        dup2(devnull, STDOUT_FILENO);
        dup2(devnull, STDERR_FILENO);
        const std::string fd = std::to_string(fds[1]);
        execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1920x1200x24", "-nolisten", "tcp", "-noreset",
               static_cast<char*>(nullptr));
        _exit(127);
    }
    close(fds[1]);
    server().pid = pid;
    std::string number;
    pollfd p{fds[0], POLLIN, 0};
    char c = 0;
    while (poll(&p, 1, 20000) > 0 && read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    close(fds[0]);
    if (number.empty())
        throw OutputError(
            "rendering needs an X display: DISPLAY is unset or does not answer, and Xvfb could not be "
            "started (install the 'xvfb' package; tools/setup does)");
    return ":" + number;
}

}  // namespace

void ensureDisplay() {
    static std::mutex mutex;
    std::lock_guard<std::mutex> lock(mutex);
    const char* current = std::getenv("DISPLAY");
    if (heldConnection()) return;
    if (current && *current && displayAnswers(current)) return;
    const std::string name = startXvfb();
    setenv("DISPLAY", name.c_str(), 1);
    if (!displayAnswers(name.c_str())) throw OutputError("rendering: the Xvfb started on " + name + " does not answer");
}

}  // namespace gpisvdb
