#pragma once
// Contact geometry of the fragment shapes: how far a body reaches along a direction (its support
// function) and where it touches a plane. The bounce model (core/impact) uses these to find when
// an oriented body first touches a terrain triangle and the lever arm r of the contact impulse.
//
// All functions take the body's attitude q (body -> site) and work in site axes, relative to the
// centre of mass. Convex bodies only (all fragment shapes are).
#include "core/common/types.h"
#include "core/fragments/group.h"
#include "core/fragments/sampling.h"

namespace fragsim::fragments {

// The solid that touches the ground. A point mass behaves as a small sphere of the same
// presented area (radius sqrt(A / pi)), as the bounce issue specifies.
// A polyhedron is its group's shared hull (never copied) scaled by `scale`.
struct ContactBody {
  ShapeType type = ShapeType::kSphere;  // never kPoint: resolved to kSphere
  Vec3 half_m{0, 0, 0};  // sphere: (r, r, r); cuboid, ellipsoid: semi-axes; cylinder: (R, R, L/2);
                         // polyhedron: half its bounding box along the body axes
  Vec3 inertia_kg_m2{0, 0, 0};  // principal moments (a point mass gets the sphere's 2/5 m r^2)
  std::shared_ptr<const Polyhedron> polyhedron;  // polyhedron only
  double scale = 1.0;                            // polyhedron: x_body = scale * hull vertex
};

ContactBody contact_body(ShapeType type, const MassProperties& mp);

// Volume of the body (a point mass: of its sphere).
double body_volume(const ContactBody& b);

// Largest distance from the centre of mass to any point of the body: no part of the body is
// farther away than this, whatever the attitude.
double bounding_radius(const ContactBody& b);

// Support function h(d) = max over body points x of d . x (x relative to the centre of mass,
// site axes), for a unit direction d in site axes. The body touches a plane with unit normal n
// when the centre's height above it equals support_extent(b, q, -n).
double support_extent(const ContactBody& b, const Quat& q, const Vec3& d);

// Where a body lying on a plane with unit normal n (pointing from the plane toward the body)
// touches it, relative to the centre of mass in site axes: the centroid of the body's points
// that lie within `flat_tol_m` of the lowest one. A vertex, an edge (its midpoint), a face (its
// centre), a cylinder's end disk (its centre) or side line (its midpoint); a polyhedron's vertex,
// edge midpoint, or the area centroid of the polygon its touching vertices span. Taking the
// centroid of the whole contact set makes a face or edge landing symmetric: a cube landing flat
// gets its impulse under its centre of mass and no spin, whatever the order in which corners are
// listed.
Vec3 contact_point(const ContactBody& b, const Quat& q, const Vec3& n, double flat_tol_m);

// The attitude a body lying on a plane with unit normal n (from the plane toward the body)
// topples into: the least rotation of q that brings the face the body falls onto flat on the
// plane (its outward normal exactly -n). The face is the one the line from the centre of mass
// along -n leaves the body through (the quasi-static fall about the contact point: a body tips
// toward the face its centre stands over), i.e. for a cuboid the axis i with the largest
// |d_i| / a_i (d = -n in body axes, a the half sizes; ties to the smaller a_i, so a plate
// balanced exactly on an edge falls flat); for a cylinder an end disk when |d_z| / (L/2) >
// sqrt(1 - d_z^2) / R, else its side (the axis made perpendicular to n). An ellipsoid rests only
// on the ends of its shortest axis (or, with two shortest, on the circle they span). A polyhedron
// tips onto the hull face the line leaves through (the least offset_f / (n_f . d) over the faces
// with n_f . d > 0, ties to the lower face) and, while its centre does not stand over the face it
// lies on, on again the same way (the centre drops each time), to a stable face. A sphere, and
// a body whose face is already flat (tilted less than ~5e-8 rad), keeps q exactly.
Quat toppled_attitude(const ContactBody& b, const Quat& q, const Vec3& n);

// Area of the body's projection along unit direction d (site axes) at attitude q: the frontal
// area a flow along d meets. Cuboid (full sizes A, B, C): |d_x| B C + |d_y| A C + |d_z| A B;
// ellipsoid (semi-axes a, b, c): pi a b c sqrt((d_x/a)^2 + (d_y/b)^2 + (d_z/c)^2); cylinder:
// pi R^2 |d_z| + 2 R L sqrt(1 - d_z^2); sphere pi r^2; polyhedron (a closed convex surface
// covers its shadow twice) sum over faces of area_f |n_f . d| / 2 (d in body axes). Averaged over
// directions it is the surface / 4 (Cauchy).
double projected_area(const ContactBody& b, const Quat& q, const Vec3& d);

}  // namespace fragsim::fragments
