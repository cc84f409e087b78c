#include "sim/dynamics.hpp"

#include <omp.h>

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "sim/clones.hpp"

namespace minv::sim {

namespace {

// v × m for motion vectors (RBDA eq. 2.31), without forming the 6×6 matrix.
Vec6<double> crossMotion(const Vec6<double>& v, const Vec6<double>& m) {
  Vec6<double> out;
  const Eigen::Vector3d w = v.head<3>(), vl = v.tail<3>();
  out.head<3>() = w.cross(m.head<3>());
  out.tail<3>() = w.cross(m.tail<3>()) + vl.cross(m.head<3>());
  return out;
}

// v ×* f for force vectors (RBDA eq. 2.32).
Vec6<double> crossForce(const Vec6<double>& v, const Vec6<double>& f) {
  Vec6<double> out;
  const Eigen::Vector3d w = v.head<3>(), vl = v.tail<3>();
  out.head<3>() = w.cross(f.head<3>()) + vl.cross(f.tail<3>());
  out.tail<3>() = w.cross(f.tail<3>());
  return out;
}

}  // namespace

// Vectors of a joint's K DOFs (K = 1, 3, 6, or Dynamic up to 6), fixed-size where K is.
template <int K>
using VecJ = Eigen::Matrix<double, K, 1, 0, K == Eigen::Dynamic ? 6 : K, 1>;

void bodyVelocities(const Model& model, const Kinematics<double>& kin, const Eigen::VectorXd& v,
                    Mat6N<double>& V) {
  for (int i = 0; i < model.nb(); ++i) {
    const int p = model.parent(i), vi = model.vIdx(i), k = model.nvOf(i);
    forJointSize(k, [&](auto K) {
      constexpr int N = decltype(K)::value;
      const Vec6<double> vJ = kin.S.template middleCols<N>(vi, k) * v.template segment<N>(vi, k);
      V.col(i) = p >= 0 ? Vec6<double>(V.col(p) + vJ) : vJ;
    });
  }
}

// Each pass's body step on fixed-size blocks of the joint's K DOFs (forJointSize); compiled
// (the whole call tree inlined) for AVX-512 and AVX2 beside the portable build, chosen at load
// time (GCC target_clones). With vstar, pass 3 also takes the unconstrained step: v* = v + h q̈
// into vstar and V*_i = V*_λ(i) + S_i v*_i into ws.Vstar. One function for aba() and abaStep()
// (a template helper inlined into two clones left its lambdas out of line, in the portable
// build: S = 5 centipede dynamics 2.96 -> 3.65 us on Zen 5).
// Each pass is a chain of dependent per-body steps along the tree, not arithmetic: on a Zen 4
// core (S = 5 centipede) two rewrites were measured and dropped. The passes on core's Six
// columns, compiled for AVX-512 in a translation unit of their own, took 1.08-1.41 us against
// 0.98-1.18 for this code in the same standalone probe (pass 1 equal, pass 2 +110-150 ns). The
// cross products as scalars stored in aligned pairs took pass 1 from 421 to 341 ns in a
// standalone probe, but the step's dynamics stage went 2.92-2.94 -> 2.97-2.98 us (builds
// alternated, 3 rounds). The parent's vector carried in registers along chains, as the impulse
// sweeps do: the dynamics stage went 2.92-3.02 -> 3.28-3.38 us with it in all three passes, and
// stayed at 2.91-2.93 with it in passes 2 and 3 alone (3 rounds each). Pass 2's bias forces
// folded into abi's articulated pass (a per-body hook in its module, Ia_i taken from registers,
// pass 1 run there too): the stage went 2.91-2.95 -> 3.02-3.05 us. In a probe the folded bias
// forces cost 390 ns of the backward pass against 290 for pass 2 on its own: the chain
// pA_i -> u_i -> pA_λ(i) along the spine is not overlapped by the articulated step's own chain.
namespace {
MINV_CLONES_FLAT void abaPasses(const Model& model, const Kinematics<double>& kin,
                                const Articulated<double>& art, const Eigen::VectorXd& v,
                                const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity,
                                AbaWorkspace& ws, Eigen::VectorXd& qdd, double h,
                                Eigen::VectorXd* vstar) {
  const int nb = model.nb();
  // Pass 1: velocities, velocity-product accelerations c_i = V_i × S_i q̇_i, bias forces.
  for (int i = 0; i < nb; ++i) {
    const int p = model.parent(i), vi = model.vIdx(i), k = model.nvOf(i);
    forJointSize(k, [&](auto K) {
      constexpr int N = decltype(K)::value;
      const Vec6<double> vJ = kin.S.template middleCols<N>(vi, k) * v.template segment<N>(vi, k);
      const Vec6<double> V = p >= 0 ? Vec6<double>(ws.V.col(p) + vJ) : vJ;
      ws.V.col(i) = V;
      ws.c.col(i) = crossMotion(V, vJ);
      ws.pA.col(i) = crossForce(V, kin.I[i] * V);
    });
  }
  // Pass 2: u_i = τ_i − S_iᵀ pA_i; pA_λ += pA_i + Ia_i c_i + U_i D_i⁻¹ u_i with
  // Ia_i = IA_i − U_i D_i⁻¹ U_iᵀ.
  for (int i = nb - 1; i >= 0; --i) {
    const int p = model.parent(i), vi = model.vIdx(i), k = model.nvOf(i);
    forJointSize(k, [&](auto K) {
      constexpr int N = decltype(K)::value;
      const auto S = kin.S.template middleCols<N>(vi, k);
      const auto UD = art.UDinv.template middleCols<N>(vi, k);
      const VecJ<N> u = tau.template segment<N>(vi, k) - S.transpose() * ws.pA.col(i);
      ws.u.template segment<N>(vi, k) = u;
      if (p < 0) return;
      const Vec6<double> ci = ws.c.col(i);
      const VecJ<N> Utc = art.U.template middleCols<N>(vi, k).transpose() * ci;
      Vec6<double> pa = ws.pA.col(i) + art.IA[i] * ci;
      pa.noalias() += UD * (u - Utc);
      ws.pA.col(p) += pa;
    });
  }
  // Pass 3: accelerations; gravity enters as the root's fictitious acceleration −g.
  Vec6<double> a0;
  a0 << Eigen::Vector3d::Zero(), -gravity;
  for (int i = 0; i < nb; ++i) {
    const int p = model.parent(i), vi = model.vIdx(i), k = model.nvOf(i);
    forJointSize(k, [&](auto K) {
      constexpr int N = decltype(K)::value;
      const Vec6<double> ap = (p >= 0 ? Vec6<double>(ws.a.col(p)) : a0) + ws.c.col(i);
      VecJ<N> qd = art.Dinv[i].template topLeftCorner<N, N>(k, k) * ws.u.template segment<N>(vi, k);
      qd.noalias() -= art.UDinv.template middleCols<N>(vi, k).transpose() * ap;
      qdd.template segment<N>(vi, k) = qd;
      ws.a.col(i) = ap + kin.S.template middleCols<N>(vi, k) * qd;
      if (vstar) {
        // v*_i = v_i + h q̈_i, V*_i = V*_λ(i) + S_i v*_i
        const VecJ<N> vs = v.template segment<N>(vi, k) + h * qd;
        vstar->template segment<N>(vi, k) = vs;
        const Vec6<double> vJ = kin.S.template middleCols<N>(vi, k) * vs;
        ws.Vstar.col(i) = p >= 0 ? Vec6<double>(ws.Vstar.col(p) + vJ) : vJ;
      }
    });
  }
}
}  // namespace

void aba(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
         const Eigen::VectorXd& v, const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity,
         AbaWorkspace& ws, Eigen::VectorXd& qdd) {
  abaPasses(model, kin, art, v, tau, gravity, ws, qdd, 0.0, nullptr);
}

void abaStep(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
             const Eigen::VectorXd& v, const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity,
             double h, AbaWorkspace& ws, Eigen::VectorXd& qdd, Eigen::VectorXd& vstar) {
  abaPasses(model, kin, art, v, tau, gravity, ws, qdd, h, &vstar);
}

void addJacobianColumn(const Model& model, const Kinematics<double>& kin, int body,
                       const Vec6<double>& f, Eigen::MatrixXd& J, int col) {
  for (int i = body; i >= 0; i = model.parent(i)) {
    const int vi = model.vIdx(i), k = model.nvOf(i);
    J.col(col).segment(vi, k) += kin.S.middleCols(vi, k).transpose() * f;
  }
}

std::vector<int> pathDofs(const Model& model, int body) {
  std::vector<int> dofs;
  for (int i = body; i >= 0; i = model.parent(i))
    for (int d = 0; d < model.nvOf(i); ++d) dofs.push_back(model.vIdx(i) + d);
  return dofs;
}

namespace {
// Column c of the contact-space inertia: every body's ΔV for the unit impulse f_c at b_c
// (scratch receives Δq̇, unused), read at each direction's body.
void testImpulseColumn(const Model& model, const Kinematics<double>& kin,
                       const Articulated<double>& art, ImpulseWorkspace& ws,
                       const std::vector<int>& bodies, const std::vector<Vec6<double>>& wrenches,
                       int c, Eigen::MatrixXd& A, Eigen::VectorXd& scratch) {
  const int m = static_cast<int>(bodies.size());
  testImpulseResponse<double>(model, kin, art, bodies[c], wrenches[c], scratch, ws);
  for (int r = 0; r < m; ++r) A(r, c) = wrenches[r].dot(ws.dv.col(bodies[r]));
}
}  // namespace

void testImpulses(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
                  ImpulseWorkspace& ws, const std::vector<int>& bodies,
                  const std::vector<Vec6<double>>& wrenches, Eigen::MatrixXd& A,
                  Eigen::VectorXd& scratch) {
  const int m = static_cast<int>(bodies.size());
  for (int c = 0; c < m; ++c)
    testImpulseColumn(model, kin, art, ws, bodies, wrenches, c, A, scratch);
  // Symmetric up to rounding; make it exactly so.
  A = (0.5 * (A + A.transpose())).eval();
}

void testImpulses(const Model& model, const Kinematics<double>& kin, const Articulated<double>& art,
                  std::vector<ImpulseWorkspace>& ws, const std::vector<int>& bodies,
                  const std::vector<Vec6<double>>& wrenches, Eigen::MatrixXd& A,
                  std::vector<Eigen::VectorXd>& scratch) {
  const int m = static_cast<int>(bodies.size()), threads = static_cast<int>(ws.size());
  if (threads < 1 || scratch.size() != ws.size())
    throw std::invalid_argument("testImpulses: one workspace and one scratch per thread");
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
#pragma omp for schedule(dynamic, 4)
    for (int c = 0; c < m; ++c)
      testImpulseColumn(model, kin, art, ws[t], bodies, wrenches, c, A, scratch[t]);
  }
  A = (0.5 * (A + A.transpose())).eval();
}

// The update's impulse sweeps, compiled (the whole call tree inlined) for AVX-512 and AVX2 beside
// the portable build, as abaPasses. With the sweeps' chain carried in registers
// (core/impulse_sweeps.hpp) the S = 5 centipede's update stage took 0.74-0.75 us, against
// 0.84-0.91 with the carry alone (no clones); with neither 0.94, and the clones without the carry
// 0.93-0.95 (Zen 4, builds alternated, 3-4 rounds).
MINV_CLONES_FLAT void applyImpulses(const Model& model, const Kinematics<double>& kin,
                                    const Articulated<double>& art, ImpulseWorkspace& ws,
                                    const std::vector<int>& bodies,
                                    const std::vector<Vec6<double>>& wrenches,
                                    const Eigen::VectorXd& lambda, Eigen::VectorXd& dqd) {
  spatialImpulseResponse<double>(model, kin, art, bodies, wrenches, lambda, dqd, ws);
}

namespace {
// Q ← Q ⊗ exp(h ω / 2) for q(o … o+3) = (w, x, y, z), renormalised. The exponential is
// (cos φ, sin φ · ω/|ω|) with φ = h|ω|/2. Below φ = 0.02 (a step's rotation, h|ω| ≤ 0.04) cos φ
// and sin φ / φ are their Taylor series in φ², to the φ⁸ term (the first omitted one is below
// 10⁻²³), without a libm call (the renormalisation's square root aside); above, std::sin and
// std::cos.
void rotate(Eigen::VectorXd& q, int o, const Eigen::Vector3d& w, double h) {
  const double phi2 = (0.5 * h * w).squaredNorm();  // 0 for ω = 0 whatever h
  double c, s;  // cos φ and sin φ / |ω|, so that the vector part is s ω
  if (phi2 < 4e-4) {
    c = 1 - phi2 * (1.0 / 2) *
                (1 - phi2 * (1.0 / 12) * (1 - phi2 * (1.0 / 30) * (1 - phi2 * (1.0 / 56))));
    s = 0.5 * h *
        (1 - phi2 * (1.0 / 6) *
                 (1 - phi2 * (1.0 / 20) * (1 - phi2 * (1.0 / 42) * (1 - phi2 * (1.0 / 72)))));
  } else {
    const double n = w.norm(), phi = 0.5 * h * n;
    c = std::cos(phi), s = std::sin(phi) / n;
  }
  // Q ⊗ (c, s ω), then normalised.
  const double qw = q(o), qx = q(o + 1), qy = q(o + 2), qz = q(o + 3);
  const double dx = s * w.x(), dy = s * w.y(), dz = s * w.z();
  const double rw = qw * c - qx * dx - qy * dy - qz * dz;
  const double rx = qw * dx + qx * c + qy * dz - qz * dy;
  const double ry = qw * dy - qx * dz + qy * c + qz * dx;
  const double rz = qw * dz + qx * dy - qy * dx + qz * c;
  const double r = 1 / std::sqrt(rw * rw + rx * rx + ry * ry + rz * rz);
  q(o) = rw * r, q(o + 1) = rx * r, q(o + 2) = ry * r, q(o + 3) = rz * r;
}
}  // namespace

void integrate(const Model& model, Eigen::VectorXd& q, const Eigen::VectorXd& v, double h) {
  for (int i = 0; i < model.nb(); ++i) {
    const int o = model.qIdx(i), vi = model.vIdx(i);
    switch (model.joint(i).type) {
      case JointType::Revolute:
      case JointType::Prismatic:
        q(o) += h * v(vi);
        break;
      case JointType::Spherical:
        rotate(q, o, v.segment<3>(vi), h);
        break;
      case JointType::Floating: {
        const Mat3<double> R = quatToRotation<double>(q(o + 3), q(o + 4), q(o + 5), q(o + 6));
        q.segment<3>(o) += h * (R * v.segment<3>(vi + 3));
        rotate(q, o + 3, v.segment<3>(vi), h);
        break;
      }
    }
  }
}

Vec6<double> spatialMomentum(const Model& model, const Kinematics<double>& kin,
                             const Eigen::VectorXd& v) {
  Mat6N<double> V(6, model.nb());
  bodyVelocities(model, kin, v, V);
  Vec6<double> h = Vec6<double>::Zero();
  for (int i = 0; i < model.nb(); ++i) h += kin.I[i] * V.col(i);
  return h;
}

double kineticEnergy(const Model& model, const Kinematics<double>& kin, const Eigen::VectorXd& v) {
  Mat6N<double> V(6, model.nb());
  bodyVelocities(model, kin, v, V);
  double e = 0;
  for (int i = 0; i < model.nb(); ++i) e += 0.5 * V.col(i).dot(kin.I[i] * V.col(i));
  return e;
}

}  // namespace minv::sim
