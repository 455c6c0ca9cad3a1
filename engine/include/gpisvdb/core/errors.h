#pragma once
// Typed exceptions. The library never exits; the command line catches these and prints one line.
#include <cstdio>
#include <stdexcept>
#include <string>

namespace gpisvdb {

/// Base of every error the engine reports to users.
struct Error : std::runtime_error {
    using std::runtime_error::runtime_error;
};
/// The input file is missing, unreadable, malformed or holds unusable data.
struct InputError : Error {
    using Error::Error;
};
/// A parameter is out of its valid range (the message names the parameter and the range).
struct ParameterError : Error {
    using Error::Error;
};
/// An output could not be written.
struct OutputError : Error {
    using Error::Error;
};
/// A number for a message: 4 significant digits, any magnitude (1e-07, 0.01389, 6.37e+22), where std::to_string
/// would print 0.000000.
inline std::string numberText(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
}

/// The caller's interrupter asked to stop.
struct Cancelled : Error {
    Cancelled() : Error("interrupted") {}
};

}  // namespace gpisvdb
