#pragma once
// One function per subcommand: registers its flags and returns the action to run after parsing.
#include <CLI/CLI.hpp>
#include <functional>

namespace gpisvdb::cli {

using Action = std::function<void()>;
void addInfo(CLI::App& app, Action& action);
void addEvaluate(CLI::App& app, Action& action);
void addDemo(CLI::App& app, Action& action);
void addBand(CLI::App& app, Action& action);
void addGreen(CLI::App& app, Action& action);
void addGeodesic(CLI::App& app, Action& action);
void addMesh(CLI::App& app, Action& action);
void addSpectrum(CLI::App& app, Action& action);
void addRegress(CLI::App& app, Action& action);
void addHodge(CLI::App& app, Action& action);
void addDistance(CLI::App& app, Action& action);
void addRender(CLI::App& app, Action& action);
void addSample(CLI::App& app, Action& action);
void addSurfaces(CLI::App& app, Action& action);
void addQuery(CLI::App& app, Action& action);
void addConvert(CLI::App& app, Action& action);

}  // namespace gpisvdb::cli
