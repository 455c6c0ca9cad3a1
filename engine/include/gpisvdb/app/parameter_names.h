#pragma once
// The engine names a parameter by its Options field (core/errors.h); each front end by its own name. One table maps
// every field the engine's messages name to the command line's flag and the Python keyword that set it, so that the
// command line, gpisvdb-mpi and the Python module translate a message the same way and a new field is named once.
#include <string>
#include <string_view>
#include <vector>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::app {

struct ParameterName {
    std::string_view field;    ///< "Struct::field", exactly as the engine's messages name it
    std::string_view flag;     ///< the command line's flag ("--voxel-size"); empty: no flag sets it
    std::string_view keyword;  ///< the Python keyword ("voxel_size"); empty: no keyword sets it
};

/// Every Options field an engine message names, in a fixed order; a field no front end sets has an empty flag and
/// keyword (the message then keeps the field's name: it is the library's own tuning, docs/guide.md).
const std::vector<ParameterName>& parameterNames();

enum class FrontEnd { CommandLine, Python };

/// The flag (CommandLine) or keyword (Python) that sets `field` ("BarnesHutOptions::beta"); the field's own name where
/// no front end sets it or the table does not list it.
std::string_view parameterName(std::string_view field, FrontEnd frontEnd);

/// error.what() in the front end's names: every field it names becomes the flag (CommandLine) or the keyword
/// (Python); a field error.parameters() lists that the text does not write is appended in parentheses.
std::string frontEndMessage(const Error& error, FrontEnd frontEnd);

}  // namespace gpisvdb::app
