// The one table of parameter names (app/parameter_names.h): every field the engine's messages name has a row, every
// flag and keyword in it is one the command line and the Python module define, and both front ends translate with it.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "gpisvdb/app/parameter_names.h"

namespace fs = std::filesystem;
using namespace gpisvdb;
using gpisvdb::test::cli::fileText;

namespace {

const fs::path kSource = GPISVDB_SOURCE_DIR;

/// The text of every file under `dir` whose name ends with one of `extensions`, concatenated.
std::string sources(const fs::path& dir, std::initializer_list<const char*> extensions) {
    std::string text;
    for (const auto& entry : fs::recursive_directory_iterator(dir))
        for (const char* ext : extensions)
            if (entry.is_regular_file() && entry.path().extension() == ext) text += fileText(entry.path().string()) + "\n";
    return text;
}

const app::ParameterName* row(std::string_view field) {
    const auto& names = app::parameterNames();
    const auto it = std::find_if(names.begin(), names.end(), [&](const app::ParameterName& n) { return n.field == field; });
    return it == names.end() ? nullptr : &*it;
}

}  // namespace

TEST_CASE("parameter names: every Options field the engine's messages name has exactly one row", "[app]") {
    std::set<std::string> fields;
    for (const auto& n : app::parameterNames()) {
        INFO(n.field);
        CHECK(fields.insert(std::string(n.field)).second);
    }
    // The fields as the engine and gpisvdb-mpi's library write them: "Struct::field" inside a string literal.
    const std::string engine = sources(kSource / "engine", {".cpp", ".h"}) + sources(kSource / "mpi", {".cpp", ".h"});
    const std::regex literal(R"re("(?:[^"\\\n]|\\.)*")re");
    const std::regex field(R"re([A-Z][A-Za-z]*(?:Options|Panel)::[a-z][A-Za-z]*)re");
    std::size_t named = 0;
    for (std::sregex_iterator s(engine.begin(), engine.end(), literal), end; s != end; ++s) {
        const std::string text = s->str();
        for (std::sregex_iterator f(text.begin(), text.end(), field); f != end; ++f) {
            INFO(f->str() << " is named by a message but has no row in app/parameter_names.cpp");
            CHECK(fields.count(f->str()) == 1);
            ++named;
        }
    }
    CHECK(named > 100);  // the scan found the engine's messages
}

TEST_CASE("parameter names: each flag is the command line's and each keyword the Python module's", "[app]") {
    const std::string cli = sources(kSource / "tools/gpisvdb", {".cpp", ".h"});
    const std::string python = sources(kSource / "python/src", {".cpp", ".h"});
    for (const auto& n : app::parameterNames()) {
        INFO(n.field << ": " << n.flag << ", " << n.keyword);
        if (!n.flag.empty()) {
            // CLI11 names: "--flag" or "-k,--count" or "-n,--count"
            const std::string f(n.flag);
            CHECK((cli.find('"' + f + '"') != std::string::npos || cli.find('"' + f + ',') != std::string::npos ||
                   cli.find(',' + f + '"') != std::string::npos));
        }
        if (!n.keyword.empty()) CHECK(python.find('"' + std::string(n.keyword) + "\"_a") != std::string::npos);
    }
}

TEST_CASE("parameter names: a message names flags on the command line and keywords in Python", "[app]") {
    const ParameterError named("the spacing (CollisionOptions::step) must be > 0; or raise CollisionOptions::step",
                               {"CollisionOptions::step"});
    CHECK(app::frontEndMessage(named, app::FrontEnd::CommandLine) == "the spacing (--step) must be > 0; or raise --step");
    CHECK(app::frontEndMessage(named, app::FrontEnd::Python) == "the spacing (step) must be > 0; or raise step");

    // A listed field the text does not write is appended once; internal and unknown fields keep their names.
    const MemoryLimitError listed("the band needs 9 GB", {"BandOptions::maxVoxels", "DefaultBandOptions::maxMemory"});
    CHECK(app::frontEndMessage(listed, app::FrontEnd::CommandLine) == "the band needs 9 GB (--max-memory)");
    CHECK(app::frontEndMessage(listed, app::FrontEnd::Python) == "the band needs 9 GB (max_memory)");
    const ParameterError internal("cell width (BarnesHutOptions::cellWidth) must be > 0 (Foo::bar)",
                                  {"BarnesHutOptions::cellWidth", "Foo::bar"});
    REQUIRE(row("BarnesHutOptions::cellWidth") != nullptr);
    CHECK(row("BarnesHutOptions::cellWidth")->flag.empty());
    CHECK(app::frontEndMessage(internal, app::FrontEnd::CommandLine) == internal.what());
    CHECK(app::frontEndMessage(Error("no parameter"), app::FrontEnd::Python) == "no parameter");
}

TEST_CASE("parameter names: gpisvdb query names --step, not the engine's field, when the spacing is too fine", "[app][cli]") {
    const std::string bunny = (fs::path(GPISVDB_DATA_DIR) / "bunny.obj").string();
    const fs::path out = gpisvdb::test::scratchDir() / "parameter_names_query.csv";
    const auto r = gpisvdb::test::cli::run("query " + bunny + " --mesh " + bunny + " --step 1e-9 -o " + out.string());
    INFO(r.err);
    CHECK(r.code != 0);
    CHECK(r.err.find("(--step)") != std::string::npos);
    CHECK(r.err.find("Options::") == std::string::npos);
    CHECK_FALSE(fs::exists(out));
}

TEST_CASE("parameter names: every flag of every subcommand is named in docs/guide.md", "[app][cli]") {
    // The guide's command table and flag paragraphs are the users' list of flags: a flag added to the command line
    // and not there fails here. Subcommands as the top-level --help lists them; a flag with a short alias passes
    // when either is named.
    const std::string guide = fileText((kSource / "docs" / "guide.md").string());
    REQUIRE(!guide.empty());
    const auto named = [&](const std::string& flag) {
        const std::regex word("(^|[^a-z0-9-])" + flag + "([^a-z0-9-]|$)");
        return std::regex_search(guide, word);
    };
    const auto top = gpisvdb::test::cli::run("--help");
    REQUIRE(top.code == 0);
    std::vector<std::string> commands;
    const std::regex subcommand("^  ([a-z]+) {2,}");
    std::istringstream lines(top.out.substr(top.out.find("Subcommands:")));
    for (std::string line; std::getline(lines, line);)
        if (std::smatch m; std::regex_search(line, m, subcommand)) commands.push_back(m[1]);
    CHECK(commands.size() >= 16);
    const std::regex option("^ +(-([a-zA-Z]),)?--([a-z0-9-]+)");
    std::vector<std::string> missing;
    for (const std::string& c : commands) {
        const auto help = gpisvdb::test::cli::run(c + " --help");
        std::istringstream options(help.out);
        for (std::string line; std::getline(options, line);) {
            std::smatch m;
            if (!std::regex_search(line, m, option) || m[3] == "help") continue;
            if (!named("--" + std::string(m[3])) && !(m[2].matched && named("-" + std::string(m[2]))))
                missing.push_back(c + " --" + std::string(m[3]));
        }
    }
    std::string list;
    for (const auto& f : missing) list += "\n  " + f;
    INFO(commands.size() << " subcommands; flags the guide does not name:" << list);
    CHECK(missing.empty());
}
