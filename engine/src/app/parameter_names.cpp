#include "gpisvdb/app/parameter_names.h"

#include <algorithm>

namespace gpisvdb::app {

const std::vector<ParameterName>& parameterNames() {
    static const std::vector<ParameterName> kNames = {
        // === Band and its resolution
        {"BandOptions::voxelSize", "--voxel-size", "voxel_size"},
        {"BandOptions::etaRelative", "--eta", "eta"},
        {"BandOptions::iso", "--iso", "iso"},
        {"BandOptions::qmcSamples", "--qmc", "qmc"},
        {"BandOptions::maxAnisotropy", "--max-anisotropy", "max_anisotropy"},
        {"BandOptions::values", "--voxel-values", "voxel_values"},
        {"BandOptions::maxVoxels", "--max-memory", "max_memory"},
        {"BandOptions::batchVoxels", "", ""},
        {"DefaultBandOptions::maxMemory", "--max-memory", "max_memory"},
        {"DefaultBandOptions::maxBandVoxels", "--max-voxels", "max_voxels"},
        {"ResolutionOptions::resolutionScale", "--resolution-scale", "resolution_scale"},
        {"ResolutionOptions::maxAnisotropy", "--max-anisotropy", "max_anisotropy"},
        {"BandForecastOptions::patches", "", ""},
        {"BandForecastOptions::pilotVoxels", "", ""},
        // === Input noise and the model
        {"NoiseOptions::sigmaRel", "--sigma", "sigma"},
        {"CloudNoiseOptions::sigmaRel", "--sigma", "sigma"},
        {"SoupNoiseOptions::sigmaRel", "--sigma", "sigma"},
        {"CloudNoiseOptions::areaDoublings", "", ""},
        {"CloudNoiseOptions::areaGrowthPoints", "", ""},
        {"CloudNoiseOptions::areaIsotropy", "", ""},
        {"ModelOptions::smoothingRel", "--smoothing", "smoothing"},
        {"ModelOptions::noiseSmoothing", "--noise-smoothing", "noise_smoothing"},
        {"ModelOptions::mergeRel", "--merge", "merge"},
        {"BarnesHutOptions::beta", "--beta", "beta"},
        {"BarnesHutOptions::covarianceRatio", "", ""},
        {"BarnesHutOptions::cellWidth", "", ""},
        {"BarnesHutOptions::cellNodes", "", ""},
        {"BarnesHutOptions::cellSeparation", "", ""},
        {"TrainingOptions::surfacePoints", "--training-points", "training_points"},
        {"TrainingOptions::offsetRelative", "--training-offset", "training_offset"},
        {"RegressionGpisOptions::labelNoise", "--label-noise", "label_noise"},
        {"RegressionGpisOptions::amplitude", "", "amplitude"},
        // === Solvers
        {"PcgOptions::tolerance", "--tolerance", "tolerance"},
        {"PcgOptions::maxIterations", "--max-iterations", "max_iterations"},
        {"PcgOptions::preconditioner", "--preconditioner", "preconditioner"},
        {"AggregationOptions::maxLevels", "", ""},
        {"BoomerAmgOptions::strongThreshold", "", ""},
        {"BoomerAmgOptions::aggressiveLevels", "", ""},
        {"BoomerAmgOptions::maxInterpolationEntries", "", ""},
        {"EigenOptions::count", "-k", "k"},
        {"EigenOptions::subspace", "--subspace", "subspace"},
        {"EigenOptions::tolerance", "--eigen-tolerance", "eigen_tolerance"},
        {"EigenOptions::maxRestarts", "--max-restarts", "max_restarts"},
        {"EigenOptions::maxBytes", "--max-memory", "max_memory"},
        {"LobpcgOptions::tolerance", "", ""},
        {"LobpcgOptions::maxIterations", "", ""},
        {"LobpcgOptions::guard", "", ""},
        {"GeodesicOptions::maxBytes", "--max-memory", "max_memory"},
        // === Tasks
        {"MaternOptions::nu", "--nu", "nu"},
        {"MaternOptions::kappa", "--kappa", "kappa"},
        {"MaternOptions::amplitude", "--amplitude", "amplitude"},
        {"SmoothedDistanceOptions::alpha", "--alpha", "alpha"},
        {"SmoothedDistanceOptions::gridVoxelSize", "--grid-voxel-size", "grid_voxel_size"},
        {"SmoothedDistanceOptions::padding", "--padding", "padding"},
        {"SmoothedDistanceOptions::tolerance", "--distance-tolerance", "tolerance"},
        {"SmoothedDistanceOptions::maxBytes", "--max-memory", "max_memory"},
        {"SurfaceDrawOptions::count", "--count", "n"},
        {"SurfaceDrawOptions::firstDraw", "--first", "first"},
        {"SurfaceDrawOptions::openingRatio", "--draw-beta", "beta"},
        {"SurfaceDrawOptions::leafSize", "", ""},
        {"RayQueryOptions::iso", "--iso", "iso"},
        {"RayQueryOptions::step", "--step", "step"},
        {"CollisionOptions::iso", "--iso", "iso"},
        {"CollisionOptions::step", "--step", "step"},
        {"CollisionOptions::draws", "--draws", "draws"},
        // === Outputs
        {"VdbWriteOptions::halfFloat", "--half", "half"},
        {"VdbWriteOptions::occupancyName", "--fog-name", "fog_name"},
        {"RenderPanel::logScale", "--log", ""},
        {"RenderPanel::slice", "--slice", ""},
    };
    return kNames;
}

std::string_view parameterName(std::string_view field, FrontEnd frontEnd) {
    const auto& names = parameterNames();
    const auto row = std::find_if(names.begin(), names.end(), [&](const ParameterName& n) { return n.field == field; });
    if (row == names.end()) return field;
    const std::string_view name = frontEnd == FrontEnd::CommandLine ? row->flag : row->keyword;
    return name.empty() ? field : name;
}

std::string frontEndMessage(const Error& error, FrontEnd frontEnd) {
    std::string text = error.what();
    std::vector<std::string_view> appended;
    for (const std::string& field : error.parameters()) {
        const std::string_view name = parameterName(field, frontEnd);
        if (name == field) continue;
        bool written = false;
        for (std::size_t at = text.find(field); at != std::string::npos; at = text.find(field, at + name.size())) {
            text.replace(at, field.size(), name);
            written = true;
        }
        if (!written && std::find(appended.begin(), appended.end(), name) == appended.end()) appended.push_back(name);
    }
    for (std::size_t i = 0; i < appended.size(); ++i) (text += i ? ", " : " (") += appended[i];
    if (!appended.empty()) text += ")";
    return text;
}

}  // namespace gpisvdb::app
