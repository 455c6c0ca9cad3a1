#pragma once
// Typed exceptions. The library never exits; the command line catches these and prints one line.
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace gpisvdb {

/// Base of every error the engine reports to users.
///
/// Messages speak in the library's terms: a parameter is named by its quantity and its Options field, e.g.
/// "voxel size (BandOptions::voxelSize) must be finite and > 0", and advice likewise ("use a larger voxel size
/// (BandOptions::voxelSize)"); the engine never names a command-line flag. parameters() lists, machine-readable,
/// the Options fields the message names, each exactly as written in it ("BandOptions::voxelSize",
/// "EigenOptions::maxBytes"; empty when the error is not about a parameter). A front end maps them to its own
/// names: the command line replaces each with its flag ("voxel size (--voxel-size) must be ...").
struct Error : std::runtime_error {
    explicit Error(const std::string& what, std::vector<std::string> parameters = {})
        : std::runtime_error(what),
          parameters_(parameters.empty() ? nullptr : std::make_shared<const std::vector<std::string>>(std::move(parameters))) {}
    /// The Options fields the message names ("Struct::field"), in the order it names them.
    const std::vector<std::string>& parameters() const noexcept {
        static const std::vector<std::string> none;
        return parameters_ ? *parameters_ : none;
    }

private:
    std::shared_ptr<const std::vector<std::string>> parameters_;  // shared: copying an exception never throws
};
/// The input file is missing, unreadable, malformed or holds unusable data.
struct InputError : Error {
    using Error::Error;
};
/// A parameter is out of its valid range (the message names the parameter, its Options field and the range;
/// parameters() lists the fields).
struct ParameterError : Error {
    using Error::Error;
};
/// The work would need more memory than its limit allows (a band, a march, an eigen solve or a grid refused before
/// allocating; the message names the limit and the parameter to change). A ParameterError: the fix is a parameter.
struct MemoryLimitError : ParameterError {
    using ParameterError::ParameterError;
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
