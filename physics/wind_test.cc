// Wind (physics/wind.h) against independent references: the generated turbulence's spectra against the
// analytic Dryden spectra of MIL-F-8785C, its low-altitude scales against the handbook's formulas worked by
// hand, and body drag against a falling body's analytic terminal velocity.
#include "physics/wind.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <unsupported/Eigen/FFT>
#include <vector>

namespace iapsim::physics {
namespace {

TEST(Dryden, LowAltitudeScalesFollowTheHandbook) {
  // h = 50 ft (15.24 m), W20 = 15 kt (7.72 m/s, "light"): 0.177 + 0.000823 * 50 = 0.21815
  const DrydenScales s = LowAltitudeDryden(15.24, 7.72);
  EXPECT_NEAR(s.length_w_m, 15.24, 1e-9);
  EXPECT_NEAR(s.length_u_m, 50.0 / std::pow(0.21815, 1.2) * 0.3048, 1e-9);
  EXPECT_NEAR(s.length_u_m, 94.7, 0.1);  // 0.21815^1.2 = 0.1609: 310.8 ft
  EXPECT_NEAR(s.sigma_w_mps, 0.772, 1e-12);
  EXPECT_NEAR(s.sigma_u_mps, 0.772 / std::pow(0.21815, 0.4), 1e-12);  // 1.42 m/s
  EXPECT_EQ(s.length_v_m, s.length_u_m);
  EXPECT_EQ(s.sigma_v_mps, s.sigma_u_mps);
  // below 10 ft the handbook's curves stop: the scales of 10 ft
  EXPECT_EQ(LowAltitudeDryden(0.5, 7.72).length_w_m, LowAltitudeDryden(3.048, 7.72).length_w_m);
}

// Welch's estimate (Hann windows, half overlap) of a signal's one-sided spectrum per rad/s, at bins k·Δω
std::vector<double> WelchSpectrum(const std::vector<double>& x, double dt_s, size_t segment,
                                  double* d_omega) {
  Eigen::FFT<double> fft;
  std::vector<double> window(segment), psd(segment / 2 + 1, 0.0), chunk(segment);
  double window_power = 0.0;
  for (size_t i = 0; i < segment; ++i) {
    window[i] = 0.5 - 0.5 * std::cos(2.0 * M_PI * static_cast<double>(i) / static_cast<double>(segment));
    window_power += window[i] * window[i];
  }
  int segments = 0;
  std::vector<std::complex<double>> spectrum;
  for (size_t start = 0; start + segment <= x.size(); start += segment / 2) {
    for (size_t i = 0; i < segment; ++i) chunk[i] = x[start + i] * window[i];
    fft.fwd(spectrum, chunk);
    for (size_t k = 0; k < psd.size(); ++k) psd[k] += std::norm(spectrum[k]);
    ++segments;
  }
  // one-sided, per rad/s: |X|² dt / (Σw² · π) (two-sided per rad/s is |X|² dt / (2π Σw²))
  for (double& p : psd) p *= dt_s / (window_power * M_PI * segments);
  *d_omega = 2.0 * M_PI / (static_cast<double>(segment) * dt_s);
  return psd;
}

// The generated u, v and w against Φ_u, Φ_v and Φ_w over the decade around each corner frequency V/L, in
// third-of-a-decade bands (the check: within 10 %), and their variances against σ².
TEST(Dryden, GeneratedTurbulenceHasTheDrydenSpectraAndVariances) {
  const double dt_s = 0.05, airspeed_mps = 5.0;
  const DrydenScales scales = LowAltitudeDryden(10.0, 7.72);  // L_w 10 m, L_u 67 m
  DrydenTurbulence turbulence(42);
  const size_t samples = 1 << 22;  // 58 h of air at 20 Hz
  std::vector<double> u(samples), v(samples), w(samples);
  for (size_t i = 0; i < samples; ++i) {
    const Eigen::Vector3d gust = turbulence.Step(scales, airspeed_mps, dt_s);
    u[i] = gust.x();
    v[i] = gust.y();
    w[i] = gust.z();
  }
  struct Component {
    const char* name;
    const std::vector<double>* x;
    double sigma, length;
    double (*spectrum)(const DrydenScales&, double, double);
  };
  const Component components[] = {{"u", &u, scales.sigma_u_mps, scales.length_u_m, DrydenSpectrumU},
                                  {"v", &v, scales.sigma_v_mps, scales.length_v_m, DrydenSpectrumV},
                                  {"w", &w, scales.sigma_w_mps, scales.length_w_m, DrydenSpectrumW}};
  for (const Component& c : components) {
    SCOPED_TRACE(c.name);
    double variance = 0.0;
    for (const double value : *c.x) variance += value * value;
    variance /= static_cast<double>(samples);
    EXPECT_NEAR(std::sqrt(variance), c.sigma, 0.03 * c.sigma);

    double d_omega = 0.0;
    const std::vector<double> psd = WelchSpectrum(*c.x, dt_s, 1 << 15, &d_omega);
    const double corner = airspeed_mps / c.length;
    for (double band = corner / std::sqrt(10.0); band < corner * std::sqrt(10.0) * 0.99;
         band *= std::pow(10.0, 1.0 / 3.0)) {
      double measured = 0.0, analytic = 0.0;
      for (size_t k = 1; k < psd.size(); ++k) {
        const double omega = static_cast<double>(k) * d_omega;
        if (omega < band || omega >= band * std::pow(10.0, 1.0 / 3.0)) continue;
        measured += psd[k];
        analytic += c.spectrum(scales, airspeed_mps, omega);
      }
      ASSERT_GT(analytic, 0.0) << "no bins in the band from " << band << " rad/s";
      EXPECT_NEAR(measured / analytic, 1.0, 0.10) << "band from " << band << " rad/s";
    }
  }
}

TEST(Dryden, TheSameSeedRepeatsAndAnotherDiffers) {
  const DrydenScales scales = LowAltitudeDryden(5.0, 7.72);
  DrydenTurbulence a(1), b(1), c(2);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d ga = a.Step(scales, 4.0, 0.001), gb = b.Step(scales, 4.0, 0.001),
                          gc = c.Step(scales, 4.0, 0.001);
    EXPECT_EQ(ga, gb);
    EXPECT_NE(ga, gc);
  }
}

TEST(Gust, OneMinusCosineRiseHoldAndFall) {
  DiscreteGust gust;
  gust.start_s = 3.0;
  gust.rise_s = 2.0;
  gust.hold_s = 1.0;
  gust.amplitude_W_mps = Eigen::Vector3d(4.0, -2.0, 1.0);
  const Eigen::Vector3d a = gust.amplitude_W_mps;
  EXPECT_EQ(GustVelocity_W(gust, 0.0), Eigen::Vector3d::Zero());
  EXPECT_EQ(GustVelocity_W(gust, 3.0), Eigen::Vector3d::Zero());
  EXPECT_LT((GustVelocity_W(gust, 3.5) - a * 0.5 * (1.0 - std::cos(M_PI / 4.0))).norm(), 1e-15);
  EXPECT_LT((GustVelocity_W(gust, 4.0) - 0.5 * a).norm(), 1e-15);
  EXPECT_LT((GustVelocity_W(gust, 5.0) - a).norm(), 1e-15);
  EXPECT_LT((GustVelocity_W(gust, 5.7) - a).norm(), 1e-15);
  EXPECT_LT((GustVelocity_W(gust, 6.0) - a).norm(), 1e-15);
  EXPECT_LT((GustVelocity_W(gust, 7.0) - 0.5 * a).norm(), 1e-15);
  EXPECT_LT(GustVelocity_W(gust, 8.0).norm(), 1e-15);
  EXPECT_EQ(GustVelocity_W(gust, 9.0), Eigen::Vector3d::Zero());
  // continuous and never beyond the amplitude
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  for (double t = 2.0; t < 9.0; t += 0.001) {
    const Eigen::Vector3d v = GustVelocity_W(gust, t);
    EXPECT_LT((v - last).norm(), M_PI / 2.0 * a.norm() / gust.rise_s * 0.001 + 1e-12) << t;
    EXPECT_LE(v.norm(), a.norm() + 1e-12);
    last = v;
  }
}

TEST(Drag, QuadraticPerBodyAxisInTheBodyFrame) {
  const Eigen::Vector3d area_B(0.02, 0.03, 0.05);
  const Eigen::Quaterniond q_WB(Eigen::AngleAxisd(0.5 * M_PI, Eigen::Vector3d::UnitZ()));  // x_B along y_W
  // still air, the body moving at 10 m/s along y_W, i.e. along its own x: 0.5 * 1.2 * 0.02 * 100 = 1.2 N back
  const Eigen::Vector3d force_W =
      DragForce_W(area_B, 1.2, q_WB, Eigen::Vector3d(0.0, 10.0, 0.0), Eigen::Vector3d::Zero());
  EXPECT_TRUE(force_W.isApprox(Eigen::Vector3d(0.0, -1.2, 0.0), 1e-12)) << force_W.transpose();
  // a body at rest in a wind feels the same force the other way
  const Eigen::Vector3d wind_W =
      DragForce_W(area_B, 1.2, q_WB, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 10.0, 0.0));
  EXPECT_TRUE(wind_W.isApprox(-force_W, 1e-12));
}

}  // namespace
}  // namespace iapsim::physics
