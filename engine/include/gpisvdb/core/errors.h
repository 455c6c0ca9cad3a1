#pragma once
// Typed exceptions. The library never exits; the command line catches these and prints one line.
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
/// The caller's interrupter asked to stop.
struct Cancelled : Error {
    Cancelled() : Error("interrupted") {}
};

}  // namespace gpisvdb
