// The repository stands alone: what a user clones holds every file its docs, tests and benchmarks name.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "cli_run.h"

namespace fs = std::filesystem;
using gpisvdb::test::cli::runShell;

namespace {

const fs::path kSource = GPISVDB_SOURCE_DIR;

/// The tracked files (git ls-files); without git (a source archive), every file below the source directory
/// except build trees and .git.
std::vector<fs::path> trackedFiles() {
    std::vector<fs::path> files;
    const auto r = runShell("git -C '" + kSource.string() + "' ls-files");
    if (r.code == 0 && !r.out.empty()) {
        std::istringstream lines(r.out);
        for (std::string line; std::getline(lines, line);)
            if (!line.empty()) files.push_back(kSource / line);
        return files;
    }
    for (auto it = fs::recursive_directory_iterator(kSource); it != fs::recursive_directory_iterator(); ++it) {
        const std::string name = it->path().filename().string();
        if (it->is_directory() && (name == ".git" || name.rfind("build", 0) == 0)) {
            it.disable_recursion_pending();
            continue;
        }
        if (it->is_regular_file()) files.push_back(it->path());
    }
    return files;
}

std::string readAll(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

bool isText(const fs::path& p) {
    static const std::vector<std::string> binary = {".png", ".vdb", ".jpg"};
    return std::find(binary.begin(), binary.end(), p.extension().string()) == binary.end();
}

}  // namespace

TEST_CASE("repository: no tracked file names a path outside the repository", "[repository]") {
    // Built from parts so that this file does not name it either.
    const std::vector<std::string> outside = {std::string("..") + "/shared", std::string("shared") + "/DESIGN",
                                              std::string("shared") + "/data", std::string("shared") + "/paper"};
    const auto files = trackedFiles();
    REQUIRE(files.size() > 50);
    for (const fs::path& f : files) {
        if (!isText(f) || !fs::is_regular_file(f)) continue;
        const std::string text = readAll(f);
        for (const std::string& needle : outside) {
            INFO(fs::relative(f, kSource).string() << " mentions " << needle);
            CHECK(text.find(needle) == std::string::npos);
        }
    }
}

TEST_CASE("repository: every relative link in the Markdown docs names a file of the repository", "[repository]") {
    const std::regex link(R"(\]\(([^)#\s]+)(#[^)\s]*)?\))");
    int checked = 0;
    for (const fs::path& f : trackedFiles()) {
        if (f.extension() != ".md") continue;
        const std::string text = readAll(f);
        for (auto m = std::sregex_iterator(text.begin(), text.end(), link); m != std::sregex_iterator(); ++m) {
            const std::string target = (*m)[1];
            if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
            const fs::path resolved = (f.parent_path() / target).lexically_normal();
            INFO(fs::relative(f, kSource).string() << " links " << target);
            CHECK(fs::exists(resolved));
            CHECK(resolved.string().rfind(kSource.lexically_normal().string(), 0) == 0);  // inside the repository
            ++checked;
        }
    }
    CHECK(checked > 20);
}

TEST_CASE("repository: the data the tests and benchmarks read ships with it, each file named in data/README.md", "[repository]") {
    const std::string readme = readAll(kSource / "data" / "README.md");
    REQUIRE(!readme.empty());
    int files = 0;
    for (const auto& entry : fs::directory_iterator(kSource / "data")) {
        const std::string name = entry.path().filename().string();
        if (name == "README.md") continue;
        INFO(name);
        CHECK(readme.find("`" + name + "`") != std::string::npos);
        ++files;
    }
    CHECK(files >= 5);
}

TEST_CASE("repository: bench/run --dry-run names only programs and files that exist", "[repository]") {
    const auto r = runShell("cd '" + kSource.string() + "' && bench/run --dry-run --no-build");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const std::string benchCmake = readAll(kSource / "bench" / "CMakeLists.txt");
    const auto targetsAt = benchCmake.find("add_custom_target(benchmarks");
    REQUIRE(targetsAt != std::string::npos);
    std::string benchTargets = benchCmake.substr(targetsAt, benchCmake.find(')', targetsAt) - targetsAt) + " ";
    for (char& c : benchTargets) c = std::isspace(static_cast<unsigned char>(c)) ? ' ' : c;
    int commands = 0;
    std::istringstream lines(r.err);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("+ ", 0) != 0) continue;
        ++commands;
        std::istringstream words(line.substr(2));
        std::vector<std::string> w;
        for (std::string s; words >> s;) w.push_back(s);
        if (w.size() >= 2 && w[0] == "rm") continue;  // names a file it is about to replace
        for (std::size_t i = 0; i < w.size(); ++i) {
            const std::string& word = w[i];
            INFO(line << ": " << word);
            if (word.rfind("build/bin/", 0) == 0) {
                // bench/ is EXCLUDE_FROM_ALL, so the binary need not exist: its source and its target must
                const std::string program = word.substr(10);
                CHECK(fs::exists(kSource / "bench" / (program + ".cpp")));
                CHECK(benchCmake.find("add_executable(" + program + " ") != std::string::npos);
                CHECK(benchTargets.find(" " + program + " ") != std::string::npos);
            } else if (i > 0 && w[i - 1] == "--data") {
                CHECK(fs::is_directory(kSource / word));
                CHECK(fs::exists(kSource / word / "bunny.obj"));
            } else if (word.find('/') != std::string::npos && word[0] != '-') {
                CHECK(fs::exists(kSource / word));
            }
        }
    }
    CHECK(commands >= 10);
}

TEST_CASE("repository: engine stages include only earlier stages and their own or core's private headers", "[repository]") {
    // The engine's stages in the order they build on one another (README.md, Layout): a file of one stage may
    // include public headers (engine/include/gpisvdb/<stage>/) of its own and earlier stages, private headers
    // (engine/src/<stage>/) of its own stage, and core's private helpers (SIMD lanes, vector math, Morton order).
    const std::vector<std::string> stages = {"core", "input", "model", "kacrice", "stencil", "band",
                                             "ops",  "solve", "tasks", "output",  "app"};
    auto rank = [&](const std::string& stage) {
        const auto it = std::find(stages.begin(), stages.end(), stage);
        return it == stages.end() ? -1 : int(it - stages.begin());
    };
    const std::regex include(R"re(#include\s+"([^"]+)")re");
    std::vector<std::string> crossings;
    std::size_t checked = 0;
    for (const char* root : {"engine/include/gpisvdb", "engine/src"}) {
        for (const auto& entry : fs::recursive_directory_iterator(kSource / root)) {
            if (!entry.is_regular_file()) continue;
            const fs::path rel = fs::relative(entry.path(), kSource / root);
            const std::string stage = rel.begin()->string();
            const bool isPrivate = std::string(root) == "engine/src";
            REQUIRE(rank(stage) >= 0);
            const std::string text = readAll(entry.path());
            for (std::sregex_iterator m(text.begin(), text.end(), include), end; m != end; ++m) {
                std::string target = (*m)[1];
                std::string targetStage;
                bool targetPrivate = false;
                if (target.rfind("gpisvdb/", 0) == 0) {
                    targetStage = fs::path(target.substr(8)).begin()->string();
                } else {
                    // A private header: relative to engine/src ("core/morton.h") or to the file ("../band/x.h", "x.h")
                    const fs::path beside = (entry.path().parent_path() / target).lexically_normal();
                    const fs::path fromSrc = kSource / "engine/src" / target;
                    const fs::path resolved = fs::exists(beside) ? beside : fromSrc;
                    if (!fs::exists(resolved)) continue;  // a library's header
                    targetStage = fs::relative(resolved, kSource / "engine/src").begin()->string();
                    targetPrivate = true;
                }
                ++checked;
                const bool later = rank(targetStage) > rank(stage);
                const bool foreignPrivate = targetPrivate && targetStage != stage && targetStage != "core";
                const bool privateFromPublic = targetPrivate && !isPrivate;
                if (later || foreignPrivate || privateFromPublic)
                    crossings.push_back(std::string(root) + "/" + rel.string() + " includes " + target);
            }
        }
    }
    std::string list;
    for (const auto& c : crossings) list += "\n  " + c;
    INFO(checked << " includes checked; crossings:" << list);
    CHECK(checked > 200);  // 276 when written: the scan found the engine's includes
    CHECK(crossings.empty());
}

TEST_CASE("repository: no source file of engine/, tools/, mpi/ or python/ is over 500 lines", "[repository]") {
    // Small files with self-explanatory names (DEVELOPERS.md's style): a longer one is split along what it holds.
    std::vector<std::string> long_;
    std::size_t checked = 0;
    for (const fs::path& f : trackedFiles()) {
        const std::string rel = fs::relative(f, kSource).generic_string();
        const std::string top = rel.substr(0, rel.find('/'));
        const std::string ext = f.extension().string();
        if ((top != "engine" && top != "tools" && top != "mpi" && top != "python") ||
            (ext != ".cpp" && ext != ".h" && ext != ".py" && !(ext.empty() && top == "tools")))
            continue;
        const std::string text = readAll(f);
        const auto lines = std::count(text.begin(), text.end(), '\n');
        ++checked;
        if (lines > 500) long_.push_back(rel + ": " + std::to_string(lines) + " lines");
    }
    std::string list;
    for (const auto& l : long_) list += "\n  " + l;
    INFO(checked << " files checked; over 500 lines:" << list);
    CHECK(checked > 100);
    CHECK(long_.empty());
}

TEST_CASE("repository: every C++ source file is as clang-format writes it (.clang-format)", "[repository]") {
    // One format, checked rather than reviewed (tools/format rewrites the files). The style's output changes between
    // clang-format versions: this is Debian 12's (14), which tools/setup installs.
    const auto version = runShell("clang-format --version");
    INFO("clang-format: " << version.out << version.err << " (tools/setup installs it)");
    REQUIRE(version.code == 0);
    CHECK_THAT(version.out, Catch::Contains("version 14."));
    std::string list;
    std::size_t checked = 0;
    for (const fs::path& f : trackedFiles()) {
        const std::string ext = f.extension().string();
        if (ext != ".cpp" && ext != ".h") continue;
        list += " '" + f.string() + "'";
        ++checked;
    }
    const auto r = runShell("clang-format --style=file --dry-run --Werror" + list + " 2>&1 | grep -m 20 'error:'");
    INFO(checked << " files checked; the first differences (tools/format fixes them):\n" << r.out);
    CHECK(checked > 200);
    CHECK(r.out.empty());
}

namespace {

/// The parameter names of a declaration "R f(T a, U<V, W> b = {}, …);": each parameter's last identifier before its
/// default.
std::vector<std::string> parameterNames(const std::string& declaration) {
    const std::size_t open = declaration.find('('), close = declaration.rfind(')');
    std::vector<std::string> params;
    std::string current;
    int depth = 0;
    for (std::size_t i = open + 1; i <= close; ++i) {
        const char c = declaration[i];
        if ((c == ',' && depth == 0) || i == close) {
            const std::string p = current.substr(0, current.find('='));
            std::smatch m;
            if (std::regex_search(p, m, std::regex(R"((\w+)\s*$)"))) params.push_back(m[1]);
            current.clear();
            continue;
        }
        if (c == '(' || c == '<' || c == '{') ++depth;
        if (c == ')' || c == '>' || c == '}') --depth;
        current += c;
    }
    return params;
}

}  // namespace

TEST_CASE("repository: the entry points of band/, solve/, tasks/ and app/ document parameters, result, errors, complexity and threads",
          "[repository]") {
    // The public headers' doc template (docs/README.md#the-c-library): a function that returns a stage's result
    // documents each parameter (\param, by its name: Doxygen's test checks the names), what it returns, what it
    // throws, its complexity and its thread safety. The stages listed here follow it.
    const std::regex entryPoint(
        R"(^(\w+Result|BandJob|DefaultBand|std::vector<RayHit>|InputData|InputSamples|LoadedModel|Samples) (\w+)\()");
    std::size_t checked = 0;
    for (const char* stage : {"input", "model", "band", "solve", "tasks", "app"}) {
        for (const auto& entry : fs::directory_iterator(kSource / "engine/include/gpisvdb" / stage)) {
            std::vector<std::string> lines;
            std::istringstream in(readAll(entry.path()));
            for (std::string line; std::getline(in, line);) lines.push_back(line);
            for (std::size_t i = 0; i < lines.size(); ++i) {
                std::smatch m;
                if (!std::regex_search(lines[i], m, entryPoint)) continue;
                ++checked;
                std::string declaration;
                for (std::size_t j = i; j < lines.size(); ++j) {
                    declaration += lines[j];
                    if (lines[j].find(");") != std::string::npos) break;
                }
                std::string doc;
                for (std::size_t j = i; j > 0 && lines[j - 1].rfind("///", 0) == 0; --j) doc = lines[j - 1] + "\n" + doc;
                INFO(entry.path().filename().string() << ": " << m[2] << "\n" << doc);
                for (const char* section : {"\\return ", "\\throws ", "\\par Complexity", "\\par Thread safety"})
                    CHECK(doc.find(section) != std::string::npos);
                for (const std::string& p : parameterNames(declaration)) {
                    INFO("parameter " << p);
                    CHECK(std::regex_search(doc, std::regex("\\\\param " + p + "\\b")));
                }
            }
        }
    }
    CHECK(checked >= 25);  // 25 when written: input 2, model 3, band 5, solve 5, the eight tasks, the band job's two
}
