#pragma once
// Shared by the libFuzzer targets of this folder: each writes the input to a scratch file with the reader's
// extension and calls the real reader on it. The typed errors of the engine (gpisvdb::Error: InputError for a
// malformed file) are the expected way to refuse an input; anything else that escapes (std::bad_alloc,
// std::out_of_range, openvdb::Exception, ...) reaches std::terminate, and libFuzzer reports it like a crash, an
// ASan/UBSan report or a hang (-timeout).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::fuzz {

/// The scratch file of this process, removed at exit: in $TMPDIR when set, else in /dev/shm (memory: 20 times
/// faster than rewriting a file on disk each run), else in /tmp.
inline const std::string& scratchPath(const char* extension) {
    struct Scratch {
        std::string path;
        ~Scratch() { std::remove(path.c_str()); }
    };
    static const Scratch s{[&] {
        const char* dir = std::getenv("TMPDIR");
        if (!(dir && *dir)) dir = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
        return std::string(dir) + "/gpisvdb-fuzz-" + std::to_string(::getpid()) + extension;
    }()};
    return s.path;
}

/// Writes the input to the scratch file and calls read(path); gpisvdb::Error is the expected refusal.
template <class Read>
int readAsFile(const uint8_t* data, std::size_t size, const char* extension, Read&& read) {
    const std::string& path = scratchPath(extension);
    {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
        if (!out) std::abort();  // the harness itself failed: not the reader's fault, but never silent
    }
    try {
        read(path);
    } catch (const gpisvdb::Error&) {
    }
    return 0;
}

}  // namespace gpisvdb::fuzz
