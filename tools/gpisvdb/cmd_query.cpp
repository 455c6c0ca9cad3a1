// gpisvdb query INPUT (--rays R.csv | --points P.xyz | --mesh M.obj) -o OUT.csv: ray hits, points' probability of
// being inside, a mesh's probability of meeting the inside (docs/uncertainty.md#queries).
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/occupancy.h"
#include "gpisvdb/tasks/collision.h"
#include "gpisvdb/tasks/ray_query.h"
#include "memory_stage.h"
#include "number_table.h"

namespace gpisvdb::cli {

namespace {

/// Bytes per point the model's batch evaluation holds: a ValueGradient and, for Barnes–Hut, its Morton order.
constexpr double kEvaluatedPointBytes = double(sizeof(ValueGradient)) + 16.0;

struct Args {
    std::string input, rays, points, mesh, output;
    ModelFlags flags;
    double iso = std::numeric_limits<double>::quiet_NaN();   // unset: the model's own level
    double step = std::numeric_limits<double>::quiet_NaN();  // unset: s / 4 (rays), s / 2 (mesh)
    int draws = CollisionOptions{}.draws;
    std::uint64_t seed = 1;
    StageFlags stage;
};

/// The flags of `gpisvdb query`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    auto* rays = cmd.add_option("--rays", a.rays, "rays, one 'ox oy oz dx dy dz length' per line (world units)");
    auto* points = cmd.add_option("--points", a.points, "points, one 'x y z' per line (world units)");
    auto* mesh = cmd.add_option("--mesh", a.mesh, "a triangle mesh (.obj .off .ply .stl .vtp): its probability of meeting the inside");
    rays->excludes(points)->excludes(mesh);
    points->excludes(mesh);
    cmd.add_option("-o,--output", a.output, "output .csv")->required();
    addModelFlags(cmd, a.flags, true);
    cmd.add_option("--iso", a.iso, "iso-value u of the surface phi = u, inside where phi > u (default: 0.5 winding, 0 regression)");
    cmd.add_option("--step", a.step, "spacing of the points along rays or on the mesh, world units (default: s/4 rays, s/2 mesh)");
    cmd.add_option("--draws", a.draws, "--mesh: Monte Carlo draws of the GPIS (1 to 10000)")->capture_default_str();
    cmd.add_option("--seed", a.seed, "--mesh: the draws' seed")->capture_default_str();
    addStageFlags(cmd, a.stage);
}

/// What is queried: one of rays, points or a mesh (`kind` names which).
struct Queries {
    std::string kind;
    std::vector<Ray> rays;
    std::vector<Vec3d> points;
    std::optional<InputData> mesh;
};

void checkFlags(const Args& a) {
    if (a.rays.empty() + a.points.empty() + a.mesh.empty() != 2) throw ParameterError("give one of --rays, --points or --mesh");
    if (!std::isnan(a.iso) && !std::isfinite(a.iso)) throw ParameterError("--iso must be finite");
    if (!std::isnan(a.step) && (!(a.step > 0) || !std::isfinite(a.step))) throw ParameterError("--step must be finite and > 0");
    if (!a.mesh.empty() && a.flags.model != "winding") throw ParameterError("--mesh draws the winding-number model only (--model winding)");
    if (a.draws < 1 || a.draws > 10000) throw ParameterError("--draws must be between 1 and 10000");
}

Queries readQueries(const Args& a) {
    Queries q;
    if (!a.rays.empty()) {
        for (const auto& r : readNumberRows(a.rays, 7, "rays", "ox oy oz dx dy dz length")) {
            Ray ray{Vec3d(r[0], r[1], r[2]), Vec3d(r[3], r[4], r[5]), r[6]};
            if (!(ray.direction.norm() > 0)) throw InputError(a.rays + ": a ray has a zero direction");
            if (!(ray.length > 0)) throw InputError(a.rays + ": a ray has a length <= 0");
            q.rays.push_back(ray);
        }
    } else if (!a.points.empty()) {
        for (const auto& r : readNumberRows(a.points, 3, "points", "x y z", /*extraIgnored*/ true)) q.points.emplace_back(r[0], r[1], r[2]);
    } else {
        q.mesh = readInput(a.mesh);
        if (!q.mesh->soup) throw InputError(a.mesh + ": not a triangle mesh (a point cloud)");
    }
    q.kind = !q.rays.empty() ? "rays" : !q.points.empty() ? "points" : "mesh";
    return q;
}

/// The stage's memory: the model's values at the points evaluated at once (rays: a batch of at most 2^18 points or
/// one whole ray, whichever is larger; points: all), and for a mesh its sample points and the draws' noise and tree
/// (≤ 256 MB).
std::vector<std::pair<std::string, double>> queryBytes(const Queries& q, double step) {
    if (q.kind == "rays") {
        std::size_t largest = 0;
        for (const Ray& r : q.rays) largest = std::max(largest, rayPointCount(r, step));
        return {{"values", (kEvaluatedPointBytes + 24.0) * double((std::size_t(1) << 18) + largest)}};
    }
    if (q.kind == "points") return {{"values", kEvaluatedPointBytes * double(q.points.size())}};
    const double points = double(meshSamplePointCount(q.mesh->soup->vertices, q.mesh->soup->triangles, step));
    return {{"values", (kEvaluatedPointBytes + 24.0 + 8.0) * points}, {"draws", 256e6}};
}

nlohmann::json writeRayHits(const GpisModel& model, const std::vector<Ray>& rays, double iso, double step, const Progress& progress,
                            std::ostream& csv) {
    RayQueryOptions o;
    o.iso = iso, o.step = step;
    const std::vector<RayHit> hits = queryRays(model, rays, o, progress);
    csv << "ox,oy,oz,dx,dy,dz,length,p_inside_origin,p_hit,hit_distance,hit_distance_std\n";
    for (std::size_t i = 0; i < hits.size(); ++i) {
        const Ray& r = rays[i];
        csv << r.origin.x() << ',' << r.origin.y() << ',' << r.origin.z() << ',' << r.direction.x() << ',' << r.direction.y() << ','
            << r.direction.z() << ',' << r.length << ',' << hits[i].insideAtOrigin << ',' << hits[i].hit << ',' << hits[i].expected << ','
            << hits[i].stddev << '\n';
    }
    return {{"rays", rays.size()}, {"step", step}};
}

nlohmann::json writePointsInside(const GpisModel& model, const std::vector<Vec3d>& points, double iso, const Progress& progress,
                                 std::ostream& csv) {
    const std::vector<ValueGradient> values = model.evaluate(points, progress);
    csv << "x,y,z,p_inside,gamma,stddev\n";
    for (std::size_t i = 0; i < values.size(); ++i)
        csv << points[i].x() << ',' << points[i].y() << ',' << points[i].z() << ',' << insideProbability(values[i], iso) << ','
            << values[i].mean[0] << ',' << std::sqrt(std::max(values[i].cov(0, 0), 0.0)) << '\n';
    return {{"points", points.size()}};
}

nlohmann::json writeCollision(const Args& a, const LoadedModel& m, const TriangleSoup& mesh, double iso, double step,
                              const Progress& progress, std::ostream& csv) {
    CollisionOptions o;
    o.draws = a.draws, o.seed = a.seed, o.step = step, o.iso = iso;
    const CollisionResult c = collisionProbability(*m.model, m.input.samples, m.smoothing, mesh.vertices, mesh.triangles, o, progress);
    csv << "points,p_collision,standard_error,largest_point_p_inside\n"
        << c.points << ',' << c.probability << ',' << c.standardError << ',' << c.largestInside << '\n';
    if (!a.flags.quiet)
        std::cerr << "query: P(collision) " << c.probability << " +- " << c.standardError << " over " << a.draws << " draws, " << c.points
                  << " points on the mesh\n";
    return {{"mesh", a.mesh},
            {"points", c.points},
            {"step", step},
            {"draws", a.draws},
            {"seed", a.seed},
            {"p_collision", c.probability},
            {"standard_error", c.standardError}};
}

/// `gpisvdb query` once its flags are parsed.
void execute(Args& a) {
    checkFlags(a);
    const InputData data = readInput(a.input);
    const Queries q = readQueries(a);
    const double limit = memoryLimit(a.stage);
    AtomicOutput out(a.output);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.stage.report);
    const LoadedModel m = loadModel(data, modelOptions(a.flags));
    const double iso = std::isnan(a.iso) ? m.model->naturalIso() : a.iso;
    const Progress progress = makeProgress(a.flags.quiet);
    std::ofstream csv(out.tempPath());
    csv << std::setprecision(17);
    const double step = !std::isnan(a.step) ? a.step : m.smoothing / (q.kind == "mesh" ? 2.0 : 4.0);
    const MemoryEstimate memory = estimateStageWithin(limit, "query", "libraries, input, model", queryBytes(q, step),
                                                      [](double, double) { return std::string("query fewer rays or points"); });
    const bool stageOnly = resetPeakResident();
    const nlohmann::json section = q.kind == "rays"     ? writeRayHits(*m.model, q.rays, iso, step, progress, csv)
                                   : q.kind == "points" ? writePointsInside(*m.model, q.points, iso, progress, csv)
                                                        : writeCollision(a, m, *q.mesh->soup, iso, step, progress, csv);
    csv.close();
    if (!csv) throw OutputError(a.output + ": writing failed (disk full?)");
    const double peak = peakResidentBytes();
    out.commit();
    if (reportOut) {
        nlohmann::json report = stageReport("query", memoryStageReport(memory, peak, stageOnly));
        report["query"] = section;
        report["outputs"] = {a.output};
        commitReport(*reportOut, report);
    }
}

}  // namespace

void addQuery(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "query",
        {"where rays first hit the uncertain surface, points' and a mesh's probability of being inside, as CSV",
         "Columns: --rays: ox,oy,oz,dx,dy,dz,length,p_inside_origin,p_hit,hit_distance,hit_distance_std\n"
         "(a hit: the ray first enters phi > u within its length; the distance's mean and std given a hit;\n"
         "Rice's rate of entries, docs/uncertainty.md#ray-queries); --points: x,y,z,p_inside,gamma,stddev;\n"
         "--mesh: points,p_collision,standard_error,largest_point_p_inside (Monte Carlo over --draws draws;\n"
         "the winding-number model only).\n"
         "Example:\n  gpisvdb query bunny.obj --rays rays.csv -o hits.csv --sigma 1"},
        addFlags, [](Args& a) -> int& { return a.flags.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
