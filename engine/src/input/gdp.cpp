#include "gpisvdb/input/gdp.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <fstream>
#include <string_view>

#include "gpisvdb/core/errors.h"
#include "readers.h"

namespace gpisvdb {

namespace {

constexpr double kRelativeTolerance = 1e-6;                   // symmetry, isotropy and cross terms, against the covariance's scale
constexpr std::string_view kLengthScaleKey = "length_scale";  // the comment "# length_scale L" after the dipoles

/// White-space separated tokens of a text with the line each starts on.
class Tokens {
public:
    Tokens(const std::string& text, const std::string& path) : text_(text), path_(path) {}
    /// The line of the last token read.
    std::size_t line() const { return tokenLine_; }
    /// The next token; with sameLine, only if it is on the line of the last one.
    bool next(std::string_view& token, bool sameLine = false) {
        while (at_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[at_]))) {
            if (sameLine && text_[at_] == '\n') return false;
            line_ += text_[at_++] == '\n';
        }
        if (at_ == text_.size()) return false;
        const std::size_t start = at_;
        tokenLine_ = line_;
        while (at_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[at_]))) ++at_;
        token = std::string_view(text_).substr(start, at_ - start);
        return true;
    }
    void skipLine() {
        while (at_ < text_.size() && text_[at_] != '\n') ++at_;
    }
    /// The next token as a finite double; `ending` says what the file lacks when it ends here.
    double number(const std::string& what, const std::string& ending) {
        std::string_view t;
        if (!next(t)) detail::fail(path_, tokenLine_, "the file ends early: " + ending);
        std::string_view digits = t;
        if (digits.size() > 1 && digits[0] == '+') digits.remove_prefix(1);
        double v = 0;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
        if (ec == std::errc::result_out_of_range || (ec == std::errc() && end == digits.data() + digits.size() && !std::isfinite(v)))
            detail::fail(path_, line_, "non-finite " + what + " '" + std::string(t) + "'");
        if (ec != std::errc() || end != digits.data() + digits.size())
            detail::fail(path_, line_, "expected a number for " + what + ", got '" + std::string(t) + "'");
        return v;
    }

private:
    const std::string& text_;
    const std::string& path_;
    std::size_t at_ = 0, line_ = 1, tokenLine_ = 1;
};

std::string text(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

/// Checks one dipole's 6×6 covariance against what the model carries; returns (v, Σ').
std::pair<double, Sym3> dipoleNoise(const Eigen::Matrix<double, 6, 6>& C, const std::string& where) {
    // === Symmetric, against the diagonal's scale
    for (int r = 0; r < 6; ++r)
        for (int c = r + 1; c < 6; ++c)
            if (std::abs(C(r, c) - C(c, r)) > kRelativeTolerance * std::sqrt(std::abs(C(r, r) * C(c, c))))
                throw InputError(where + "its covariance is not symmetric (row " + std::to_string(r + 1) + ", column " +
                                 std::to_string(c + 1) + ": " + text(C(r, c)) + " against " + text(C(c, r)) + ")");
    const Eigen::Matrix<double, 6, 6> S = 0.5 * (C + C.transpose());
    const Mat3d P = S.topLeftCorner<3, 3>(), N = S.bottomRightCorner<3, 3>(), X = S.topRightCorner<3, 3>();
    // === Position block v I, v > 0
    const double v = P.trace() / 3;
    if (!(v > 0)) throw InputError(where + "its position variance (the trace of the position block / 3) must be > 0, got " + text(v));
    if ((P - v * Mat3d::Identity()).cwiseAbs().maxCoeff() > kRelativeTolerance * v) {
        const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Mat3d>(P, Eigen::EigenvaluesOnly).eigenvalues();
        throw InputError(where + "its position covariance is not isotropic (eigenvalues " + text(e(0)) + ", " + text(e(1)) + ", " +
                         text(e(2)) + "): gpisvdb's model carries position noise sigma^2 I only");
    }
    // === No position–normal cross term, against √(v · the normal block's largest variance)
    const double crossScale = std::sqrt(v * std::max(0.0, N.diagonal().maxCoeff()));
    if (X.cwiseAbs().maxCoeff() > kRelativeTolerance * crossScale)
        throw InputError(where + "its position-normal cross-covariance is not 0 (largest entry " + text(X.cwiseAbs().maxCoeff()) +
                         "): gpisvdb's model takes a sample's position and normal noise as independent");
    // === Σ' positive semi-definite
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Mat3d>(N, Eigen::EigenvaluesOnly).eigenvalues();
    if (e(0) < -kRelativeTolerance * std::max(0.0, e(2)) || !(e(2) >= 0))
        throw InputError(where + "its normal covariance is not positive semi-definite (eigenvalues " + text(e(0)) + ", " + text(e(1)) +
                         ", " + text(e(2)) + ")");
    return {v, Sym3::from(N)};
}

}  // namespace

namespace detail {

InputData readGdp(const std::string& path) {
    const std::string bytes = slurp(path);
    if (looksBinary(bytes)) fail(path, 0, "binary content: this is not a text .gdp file");
    Tokens tokens(bytes, path);
    // === Header "3 N"
    const std::string header = "the header 'D N' (dimension 3, the number of dipoles)";
    const double dim = tokens.number("the dimension", header);
    if (dim != 3) fail(path, tokens.line(), "expected the dimension 3 in the header 'D N', got " + text(dim));
    const double declared = tokens.number("the number of dipoles", header);
    if (!(declared >= 1) || declared != std::floor(declared))
        fail(path, tokens.line(), "expected the number of dipoles (a whole number >= 1) in the header 'D N', got " + text(declared));
    checkSampleCount(path, declared > 1e18 ? std::size_t(-1) : std::size_t(declared), "dipoles");
    const std::size_t n = std::size_t(declared);

    // === Dipoles: p, w, the 6×6 covariance of (p, w)
    InputData data;
    data.cloud.emplace();
    PointCloud& c = *data.cloud;
    c.vectorAreas = true;
    // A count is no promise of data: a dipole takes 42 numbers of at least 2 bytes each
    const std::size_t promised = std::min(n, bytes.size() / 84 + 1);
    c.positions.reserve(promised), c.normals.reserve(promised), c.positionVariances.reserve(promised);
    c.areas.reserve(promised), c.normalCovariances.reserve(promised);
    for (std::size_t i = 0; i < n; ++i) {
        const std::string ending =
            "it declares " + std::to_string(n) + " dipoles (3 + 3 + 36 numbers each) and ends in dipole " + std::to_string(i + 1);
        Vec3d p, w;
        for (int k = 0; k < 3; ++k) p[k] = tokens.number("a position", ending);
        const std::size_t line = tokens.line();
        for (int k = 0; k < 3; ++k) w[k] = tokens.number("a vector area (normal)", ending);
        Eigen::Matrix<double, 6, 6> C;
        for (int r = 0; r < 6; ++r)
            for (int k = 0; k < 6; ++k) C(r, k) = tokens.number("a covariance entry", ending);
        const std::string where = path + ":" + std::to_string(line) + ": dipole " + std::to_string(i + 1) + ": ";
        if (!(w.norm() > 0)) throw InputError(where + "its vector area (the area-weighted normal) is 0");
        const auto [v, Sigma] = dipoleNoise(C, where);
        c.positions.push_back(p);
        c.normals.push_back(w);
        c.positionVariances.push_back(v);
        c.areas.push_back(w.norm());
        c.normalCovariances.push_back(Sigma);
    }
    // === After the dipoles: comment lines only, one of which may give ℓ (what writeGdp adds; readers that stop
    //     after the N dipoles, as the paper's does, never see them)
    std::string_view extra;
    while (tokens.next(extra)) {
        if (extra[0] != '#')
            fail(
                path, tokens.line(),
                "more numbers than the " + std::to_string(n) + " dipoles the header declares ('" + std::string(extra.substr(0, 32)) + "')");
        const std::size_t line = tokens.line();
        std::string_view key = extra.substr(1);
        if (key.empty() && !tokens.next(key, /*sameLine*/ true)) continue;
        if (key != kLengthScaleKey) {
            tokens.skipLine();
            continue;
        }
        const double ell = tokens.number("the length scale", "'# " + std::string(kLengthScaleKey) + " L' needs L");
        if (!(ell > 0) || tokens.line() != line) fail(path, line, "the length scale must be a number > 0 on its comment's line");
        c.lengthScale = ell;
        tokens.skipLine();
    }
    return data;
}

}  // namespace detail

void writeGdp(const Samples& S, const std::string& path) {
    const std::size_t n = S.size();
    if (S.normal.size() != n || S.positionVariance.size() != n || S.normalCovariance.size() != n)
        throw Error("writeGdp: the samples' arrays differ in length");
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw OutputError(path + ": cannot write the .gdp file");
    std::string buffer;
    buffer.reserve(1 << 20);
    auto put = [&](double v, char after) {
        char digits[32];
        const auto r = std::to_chars(digits, digits + sizeof digits, v);
        buffer.append(digits, r.ptr);
        buffer.push_back(after);
    };
    buffer += "3 " + std::to_string(n) + "\n";
    for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) put(S.position[i][k], k < 2 ? ' ' : '\n');
        for (int k = 0; k < 3; ++k) put(S.normal[i][k], k < 2 ? ' ' : '\n');
        const Mat3d N = S.normalCovariance[i].matrix();
        for (int r = 0; r < 6; ++r)
            for (int k = 0; k < 6; ++k) {
                const double v = r < 3 ? (k == r ? S.positionVariance[i] : 0.0) : (k < 3 ? 0.0 : N(r - 3, k - 3));
                put(v, k < 5 ? ' ' : '\n');
            }
        if (buffer.size() > (1u << 20) - 2048) {
            out.write(buffer.data(), std::streamsize(buffer.size()));
            buffer.clear();
        }
    }
    if (S.lengthScale > 0) {
        buffer += "# " + std::string(kLengthScaleKey) + " ";
        put(S.lengthScale, '\n');
    }
    out.write(buffer.data(), std::streamsize(buffer.size()));
    out.flush();
    if (!out) throw OutputError(path + ": cannot write the .gdp file (disk full?)");
}

}  // namespace gpisvdb
