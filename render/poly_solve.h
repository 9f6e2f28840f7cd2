#pragma once
// Real roots of polynomials of degree <= 4 in double precision, for the analytic root search
// (issue: analytic root search). Along a ray o + t d every quadric, torus or plane leaf of a
// model is a polynomial in t of degree <= 4; its real roots are the only places where that
// leaf's surface can be crossed.
//
// Method: the leading coefficient is dropped while it is negligible next to the others (a ray
// parallel to an axis or a plane lowers the degree), then closed forms give first
// approximations: the quadratic without cancellation, the cubic by Cardano (trigonometric form
// when there are three real roots), the quartic by Ferrari's resolvent cubic. Every root is then
// polished by Newton on the original polynomial, and roots that agree to rounding are merged so
// that a double or triple root is reported once. Closed forms lose accuracy near multiple roots
// (a double root is only determined to about sqrt(eps)); that is the accuracy this contract
// promises for them.

namespace hfrt::render {

/// Real roots of c[0] + c[1] t + c[2] t^2 + c[3] t^3 + c[4] t^4, ascending, each distinct root
/// once; returns how many (0..4). Leading coefficients that vanish relative to the others drop
/// the degree (rays parallel to an axis/plane). Quadratic without cancellation, cubic by Cardano
/// (trigonometric form for three real roots), quartic by Ferrari, each root polished by Newton
/// on the polynomial; double and triple roots handled; no spurious real roots. A polynomial that
/// is identically zero (or a non-zero constant) has no isolated roots: returns 0.
int solve_polynomial(const double c[5], double roots[4]);

/// The same for one fixed degree (c[degree] != 0 expected; smaller leading terms fall back to a
/// lower degree). Exposed for tests.
int solve_quadratic(double c0, double c1, double c2, double roots[2]);
int solve_cubic(double c0, double c1, double c2, double c3, double roots[3]);
int solve_quartic(double c0, double c1, double c2, double c3, double c4, double roots[4]);

}  // namespace hfrt::render
