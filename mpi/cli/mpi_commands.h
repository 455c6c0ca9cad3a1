#pragma once
// gpisvdb-mpi's subcommands: each registers its flags (those of gpisvdb's command of the same name) and returns the
// action every rank runs after parsing.
#include <CLI/CLI.hpp>

#include "commands.h"
#include "gpisvdb/mpi/ranks.h"

namespace gpisvdb::cli {

void addMpiBand(CLI::App& app, Action& action, const mpi::Ranks& ranks);
void addMpiGreen(CLI::App& app, Action& action, const mpi::Ranks& ranks);
void addMpiSpectrum(CLI::App& app, Action& action, const mpi::Ranks& ranks);
void addMpiGeodesic(CLI::App& app, Action& action, const mpi::Ranks& ranks);
void addMpiRegress(CLI::App& app, Action& action, const mpi::Ranks& ranks);

}  // namespace gpisvdb::cli
