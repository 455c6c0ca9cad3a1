// gpisvdb evaluate INPUT --at POINTS.xyz -o OUT.csv: mean and covariance of (φ, ∇φ) at query points.
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/output/occupancy.h"
#include "memory_stage.h"
#include "number_table.h"

namespace gpisvdb::cli {

namespace {

/// One 'x y z' per line (commas or spaces; '#' comments; further words, such as an .xyz cloud's normals, ignored).
std::vector<Vec3d> readQueryPoints(const std::string& path) {
    std::vector<Vec3d> xs;
    for (const auto& row : readNumberRows(path, 3, "query points", "x y z", /*extraIgnored*/ true)) xs.emplace_back(row[0], row[1], row[2]);
    return xs;
}

struct Args {
    std::string input, at, output;
    ModelFlags flags;
    double iso = std::numeric_limits<double>::quiet_NaN();  // unset: the model's own level
    int qmc = 512;
    StageFlags stage;
};

/// The flags of `gpisvdb evaluate`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("--at", a.at, "query points, one 'x y z' per line (world units)")->required();
    cmd.add_option("-o,--output", a.output, "output CSV")->required();
    addModelFlags(cmd, a.flags, true);
    cmd.add_option("--iso", a.iso, "iso-value u of the surface phi = u, for mu, T and p_inside (default: 0.5 winding, 0 regression)");
    cmd.add_option("--qmc", a.qmc, "QMC points S for mu and T (>= 1)")->capture_default_str();
    addStageFlags(cmd, a.stage);
}

/// The evaluation's memory (docs/memory.md#evaluate): a ValueGradient per point (mean and covariance in double,
/// 160 B) and, for the Barnes–Hut model, its Morton order (a 64-bit key and a 32-bit index, 16 B). The points
/// themselves (24 B each) are read before, in the baseline.
MemoryEstimate estimateEvaluation(double limit, const GpisModel& model, std::size_t count) {
    const bool barnesHut = dynamic_cast<const BarnesHutGpis*>(&model) != nullptr;
    const double perPoint = double(sizeof(ValueGradient)) + (barnesHut ? 16.0 : 0.0), n = double(count);
    std::vector<std::pair<std::string, double>> parts = {{"values", double(sizeof(ValueGradient)) * n}};
    if (barnesHut) parts.emplace_back("morton_order", 16.0 * n);
    return estimateStageWithin(limit, "evaluation of " + std::to_string(count) + " points", "libraries, input, model, points",
                               std::move(parts), [&](double, double available) {
                                   return "split the query points (--at) into files of at most " +
                                          numberText(std::floor(available / perPoint)) + " points";
                               });
}

/// One row per point: the point, the mean and covariance of (φ, ∇φ), μ and T, and the probability of being inside.
void writeRows(std::ostream& csv, const std::vector<Vec3d>& xs, const std::vector<ValueGradient>& values, double iso, const QmcRule& rule) {
    csv << "x,y,z,gamma,gx,gy,gz,c00,c01,c02,c03,c11,c12,c13,c22,c23,c33,mu,Txx,Txy,Txz,Tyy,Tyz,Tzz,p_inside\n" << std::setprecision(17);
    for (std::size_t i = 0; i < xs.size(); ++i) {
        const ValueGradient& v = values[i];
        csv << xs[i].x() << ',' << xs[i].y() << ',' << xs[i].z();
        for (int k = 0; k < 4; ++k) csv << ',' << v.mean[k];
        for (int r = 0; r < 4; ++r)
            for (int c = r; c < 4; ++c) csv << ',' << v.cov(r, c);
        const SurfaceDensity d = kacRice(v, iso, rule);
        csv << ',' << d.mu;
        for (int r = 0; r < 3; ++r)
            for (int c = r; c < 3; ++c) csv << ',' << d.T(r, c);
        csv << ',' << insideProbability(v, iso) << '\n';
    }
}

/// `gpisvdb evaluate` once its flags are parsed.
void execute(Args& a) {
    const InputData data = readInput(a.input);
    const std::vector<Vec3d> xs = readQueryPoints(a.at);
    if (!std::isnan(a.iso) && !std::isfinite(a.iso)) throw ParameterError("--iso must be finite");
    const QmcRule rule(a.qmc);
    const double limit = memoryLimit(a.stage);
    AtomicOutput out(a.output);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.stage.report);
    const LoadedModel m = loadModel(data, modelOptions(a.flags));
    const double iso = std::isnan(a.iso) ? m.model->naturalIso() : a.iso;
    const MemoryEstimate memory = estimateEvaluation(limit, *m.model, xs.size());
    const bool stageOnly = resetPeakResident();
    const auto values = m.model->evaluate(xs, makeProgress(a.flags.quiet));
    std::ofstream csv(out.tempPath());
    writeRows(csv, xs, values, iso, rule);
    csv.close();
    if (!csv) throw OutputError(a.output + ": writing failed (disk full?)");
    const double peak = peakResidentBytes();
    out.commit();
    if (reportOut) {
        nlohmann::json report = stageReport("evaluate", memoryStageReport(memory, peak, stageOnly));
        report["points"] = xs.size();
        report["outputs"] = {a.output};
        commitReport(*reportOut, report);
    }
}

}  // namespace

void addEvaluate(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "evaluate",
        {"mean and covariance of (phi, grad phi) at query points, as CSV",
         "Columns: x,y,z,gamma,gx,gy,gz,c00,c01,c02,c03,c11,c12,c13,c22,c23,c33 (c: covariance of\n"
         "(phi, d/dx phi, d/dy phi, d/dz phi), upper triangle row by row), then the Kac-Rice surface\n"
         "density mu and tangent tensor T: mu,Txx,Txy,Txz,Tyy,Tyz,Tzz (world units^-1), then p_inside,\n"
         "the probability P(phi > u) that the point lies inside the surface.\n"
         "Example:\n  gpisvdb evaluate bunny.obj --at points.xyz -o values.csv --sigma 0.25"},
        addFlags, [](Args& a) -> int& { return a.flags.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
