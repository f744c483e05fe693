// filter_cycle.cpp -- the safety filter's whole cycle from C++17 (velfence_filter.h).
//
// The same arm and scene as filter_cycle.c (a Panda-like 7-joint arm from Franka's modified DH
// table, a TCP box, 20 sphere obstacles), wrapped in a small RAII class that owns the scratch
// (allocated once, before the loop: the cycle itself allocates nothing). A 1 kHz loop
// (clock_nanosleep to absolute deadlines) or back-to-back; prints median, p99 and max cycle time and
// the deadline fallbacks; exits non-zero unless every output met every row.
//
//   filter_cycle_cpp [--cycles N] [--back-to-back] [--budget SECONDS]
//
// Build: cc -std=c99 -O2 -c core/src/velfence_filter.c core/src/velfence_nd.c -Icore/include
//        c++ -std=c++17 -O2 -Icore/include core/examples/filter_cycle.cpp velfence_filter.o
//        velfence_nd.o -lm
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "velfence_filter.h"

namespace {

constexpr int kJoints = 7;
constexpr double kDt = 0.001;
constexpr double kHalfPi = 1.5707963267948966;

// Modified DH (Craig) rows: a_{i-1} [m], alpha_{i-1} [rad], d_i [m].
constexpr std::array<std::array<double, 3>, kJoints> kMdh{{{0.0, 0.0, 0.333},
                                                           {0.0, -kHalfPi, 0.0},
                                                           {0.0, kHalfPi, 0.316},
                                                           {0.0825, kHalfPi, 0.0},
                                                           {-0.0825, -kHalfPi, 0.384},
                                                           {0.0, kHalfPi, 0.0},
                                                           {0.088, kHalfPi, 0.0}}};
constexpr std::array<double, kJoints> kLower{-2.8973, -1.7628, -2.8973, -3.0718,
                                             -2.8973, -0.0175, -2.8973};
constexpr std::array<double, kJoints> kUpper{2.8973, 1.7628, 2.8973, -0.0698,
                                             2.8973, 3.7525, 2.8973};
constexpr std::array<double, kJoints> kVmax{2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
constexpr std::array<double, kJoints> kAmax{15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0};

// The filter description and its scratch, built once.
class SafetyFilterC {
  public:
    SafetyFilterC(const std::vector<double> &centres, const std::vector<double> &radii)
        : centres_(centres), radii_(radii)
    {
        for (int j = 0; j < kJoints; ++j) {
            const double a = kMdh[j][0], c = std::cos(kMdh[j][1]), s = std::sin(kMdh[j][1]);
            const double d = kMdh[j][2];
            const double T[12] = {1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d};
            std::memcpy(joints_[j].T, T, sizeof T);
            joints_[j].axis[0] = 0.0;
            joints_[j].axis[1] = 0.0;
            joints_[j].axis[2] = 1.0;
            joints_[j].type = VF_FILTER_REVOLUTE;
            joints_[j].offset = 0.0;
            const double K = 2.0 * kAmax[j] / kVmax[j], dint = (kAmax[j] / K) / K;
            jkind_[j] = VF_ND_PROFILE_THREE_ZONE;
            const double prm[6] = {K, kVmax[j], kAmax[j], dint, 0.5 * dint,
                                   0.5 * dint + (kVmax[j] / kAmax[j]) * (0.5 * kVmax[j])};
            std::copy(prm, prm + 6, jprm_.begin() + 6 * j);
            lrad_[j] = 0.06;
        }
        f_ = vf_filter{};
        const double tool[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.207};
        std::memcpy(f_.tool, tool, sizeof tool);
        box_.point = 0;
        box_.nf = 6;
        box_.N = kBoxN.data();
        box_.off = kBoxOff.data();
        box_.kind = VF_ND_PROFILE_LINEAR;
        std::fill(std::begin(box_.prm), std::end(box_.prm), 0.0);
        box_.prm[0] = 0.05;
        f_.n = kJoints;
        f_.joints = joints_.data();
        f_.lower = kLower.data();
        f_.upper = kUpper.data();
        f_.vmax = kVmax.data();
        f_.amax = kAmax.data();
        f_.jkind = jkind_.data();
        f_.jprm = jprm_.data();
        f_.npoints = 1;
        f_.points = &tcp_;
        f_.nw = 1;
        f_.ws = &box_;
        f_.k = static_cast<int32_t>(radii_.size());
        f_.centres = centres_.data();
        f_.radii = radii_.data();
        f_.link_radius = lrad_.data();
        f_.obstacle_buffer = 0.05;
        f_.spring_gain = 1.0;
        f_.dt = kDt;
        if (vf_filter_check(&f_) != VF_OK) {
            throw std::invalid_argument("invalid filter description");
        }
        scratch_.resize(vf_filter_doubles(&f_));
        iscratch_.resize(vf_filter_ints(&f_));
    }
    SafetyFilterC(const SafetyFilterC &) = delete;
    SafetyFilterC &operator=(const SafetyFilterC &) = delete;

    int cycle(const double *q, const double *u, const double *previous,
              const vf_filter_opts &opts, double *out)
    {
        return vf_filter_cycle(&f_, q, u, previous, &opts, out, &info_, scratch_.data(),
                               iscratch_.data());
    }
    const vf_filter_info &info() const { return info_; }
    void kinematics(const double *q, double *P)
    {
        double axes[3 * kJoints], frames[12 * (kJoints + 2)];
        vf_filter_kinematics(&f_, q, P, axes, frames);
    }

  private:
    static constexpr std::array<double, 18> kBoxN{1, 0, 0, -1, 0, 0, 0, 1, 0,
                                                  0, -1, 0, 0, 0, 1, 0, 0, -1};
    static constexpr std::array<double, 6> kBoxOff{-0.7, -0.7, -0.7, -0.7, 0.05, -1.2};
    std::vector<double> centres_, radii_;
    std::array<vf_filter_joint, kJoints> joints_{};
    std::array<int32_t, kJoints> jkind_{};
    std::array<double, 6 * kJoints> jprm_{};
    std::array<double, kJoints> lrad_{};
    vf_filter_point tcp_{kJoints, {0.0, 0.0, 0.0}};
    vf_filter_polytope box_{};
    vf_filter f_{};
    vf_filter_info info_{};
    std::vector<double> scratch_;
    std::vector<int32_t> iscratch_;
};

constexpr std::array<double, 18> SafetyFilterC::kBoxN;
constexpr std::array<double, 6> SafetyFilterC::kBoxOff;

double now_s()
{
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Every row met to the round-off of forming x from u (1e-12 (|c| + |g|_1 (|x|_inf + |u|_inf))):
// its claimed bound,
// and min(b, 0) for the joint, workspace and obstacle rows.
bool verify(const vf_filter_info &info, const double *x, const double *u)
{
    double xn = 0.0, un = 0.0;
    for (int j = 0; j < kJoints; ++j) {
        xn = std::max(xn, std::fabs(x[j]));
        un = std::max(un, std::fabs(u[j]));
    }
    xn += un;
    for (int r = 0; r < info.m; ++r) {
        const double *g = info.G + static_cast<size_t>(r) * kJoints;
        double gx = 0.0, g1 = 0.0;
        for (int j = 0; j < kJoints; ++j) {
            gx += g[j] * x[j];
            g1 += std::fabs(g[j]);
        }
        const double claim = info.bound[r];
        if (claim != -INFINITY && gx - claim < -1e-12 * (std::fabs(claim) + g1 * xn)) {
            return false;
        }
        const double floor_b = std::min(info.b[r], 0.0);
        if (info.level[r] != VF_FILTER_LEVEL_RATE &&
            gx - floor_b < -1e-12 * (std::fabs(floor_b) + g1 * xn)) {
            return false;
        }
    }
    return true;
}

}  // namespace

int main(int argc, char **argv)
{
    long cycles = 2000;
    bool back = false;
    double budget = 0.0;
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if (arg == "--cycles" && a + 1 < argc) {
            cycles = std::atol(argv[++a]);
        } else if (arg == "--back-to-back") {
            back = true;
        } else if (arg == "--budget" && a + 1 < argc) {
            budget = std::atof(argv[++a]);
        } else {
            std::fprintf(stderr, "usage: %s [--cycles N] [--back-to-back] [--budget S]\n",
                         argv[0]);
            return 2;
        }
    }
    if (cycles < 1) {
        return 2;
    }
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::array<double, kJoints> q{0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8};
    // 20 spheres around the workspace, at least 0.3 m from the start pose's link midpoints.
    std::vector<double> centres, radii;
    {
        std::vector<double> probe_c{0.0, 0.0, 0.0}, probe_r{0.0};
        SafetyFilterC probe(probe_c, probe_r);
        double P[3 * (kJoints + 1)];
        probe.kinematics(q.data(), P);
        while (radii.size() < 20) {
            const double c[3] = {-0.7 + 1.4 * unit(rng), -0.7 + 1.4 * unit(rng),
                                 0.1 + 1.0 * unit(rng)};
            double best = INFINITY;
            for (int l = 0; l < kJoints; ++l) {
                double d2 = 0.0;
                for (int a = 0; a < 3; ++a) {
                    const double dd = c[a] - 0.5 * (P[3 * l + a] + P[3 * (l + 1) + a]);
                    d2 += dd * dd;
                }
                best = std::min(best, d2);
            }
            if (std::sqrt(best) >= 0.3) {
                centres.insert(centres.end(), c, c + 3);
                radii.push_back(0.03 + 0.05 * unit(rng));
            }
        }
    }
    SafetyFilterC filter(centres, radii);
    vf_filter_opts opts{};
    opts.time_budget = budget;
    std::array<double, kJoints> u{}, x{}, prev{}, target = q;
    std::vector<double> times(static_cast<size_t>(cycles));
    long fallbacks = 0, bad = 0;
    timespec next{};
    clock_gettime(CLOCK_MONOTONIC, &next);
    for (long c = 0; c < cycles; ++c) {
        if (c % 500 == 0) {
            for (int j = 0; j < kJoints; ++j) {
                target[j] = kLower[j] - 0.2 + (kUpper[j] - kLower[j] + 0.4) * unit(rng);
            }
        }
        for (int j = 0; j < kJoints; ++j) {
            u[j] = 3.0 * (target[j] - q[j]) + 0.4 * (unit(rng) - 0.5);
        }
        if (!back) {
            next.tv_nsec += 1000000L;
            if (next.tv_nsec >= 1000000000L) {
                next.tv_nsec -= 1000000000L;
                next.tv_sec += 1;
            }
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
        }
        const double t0 = now_s();
        const int rc = filter.cycle(q.data(), u.data(), prev.data(), opts, x.data());
        times[static_cast<size_t>(c)] = (now_s() - t0) * 1e6;
        if (rc < 0) {
            std::fprintf(stderr, "cycle %ld: status %d\n", c, rc);
            return 1;
        }
        fallbacks += (rc == VF_ITERATION_CAP || rc == VF_DEADLINE) ? 1 : 0;
        if (!verify(filter.info(), x.data(), u.data())) {
            std::fprintf(stderr, "cycle %ld: an output missed a row\n", c);
            ++bad;
        }
        for (int j = 0; j < kJoints; ++j) {
            q[j] += x[j] * kDt;
            prev[j] = x[j];
        }
    }
    std::sort(times.begin(), times.end());
    std::printf("mode %s cycles %ld median_us %.3f p99_us %.3f max_us %.3f fallbacks %ld "
                "violations %ld\n",
                back ? "back-to-back" : "periodic-1kHz", cycles, times[times.size() / 2],
                times[static_cast<size_t>(0.99 * static_cast<double>(times.size()))],
                times.back(), fallbacks, bad);
    return bad == 0 ? 0 : 1;
}
