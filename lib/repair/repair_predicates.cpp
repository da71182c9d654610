// Filtered exact intersection tests (see repair_predicates.h): CGAL 5.5's algorithms
// over the filtered orientation predicate; coplanar configurations go to CGAL whole.
#include "lib/repair/repair_predicates.h"

#include <utility>

namespace visgate::mesh {

int FilteredPredicates::plane_axis(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  // The largest normal component in double first; it is non-zero unless the triangle is
  // nearly degenerate, and orient2d decides that exactly.
  const Vec3d n = vabs(cross(b - a, c - a));
  const int first = max_axis(n);
  for (int k = 0; k < 3; ++k) {
    const int ax = (first + k) % 3;
    if (orient2d(a, b, c, ax) != 0) return ax;
  }
  return first;  // a, b, c collinear: outside the precondition
}

int FilteredPredicates::coplanar_side(const Vec3d& a, const Vec3d& b, const Vec3d& p, const Vec3d& q) const {
  const int ax = plane_axis(a, b, p);
  return orient2d(a, b, p, ax) * orient2d(a, b, q, ax);
}

namespace {

// CGAL Triangle_3_Triangle_3_do_intersect.h, _intersection_test_vertex and
// _intersection_test_edge, with o(x, y, z) the in-plane orientation; pqr and abc are
// counter-clockwise.
template <class O>
bool test_vertex(const Vec3d* p, const Vec3d* q, const Vec3d* r, const Vec3d* a, const Vec3d* b, const Vec3d* c,
                 const O& o) {
  if (o(*c, *a, *q) >= 0) {
    if (o(*c, *b, *q) <= 0) {
      if (o(*p, *a, *q) > 0) return o(*p, *b, *q) <= 0;
      return o(*p, *a, *r) >= 0 && o(*q, *r, *a) >= 0;
    }
    if (o(*p, *b, *q) <= 0) return o(*c, *b, *r) <= 0 && o(*q, *r, *b) >= 0;
    return false;
  }
  if (o(*c, *a, *r) >= 0) {  // qr straddles (ac)
    if (o(*q, *r, *c) >= 0) return o(*p, *a, *r) >= 0;
    return o(*q, *r, *b) >= 0 && o(*c, *r, *b) >= 0;
  }
  return false;  // ca separates
}

template <class O>
bool test_edge(const Vec3d* p, const Vec3d* q, const Vec3d* r, const Vec3d* a, const Vec3d* c, const O& o) {
  if (o(*c, *a, *q) >= 0) {  // pq straddles (ac)
    if (o(*p, *a, *q) >= 0) return o(*p, *q, *c) >= 0;
    return o(*q, *r, *a) >= 0 && o(*r, *p, *a) >= 0;
  }
  if (o(*c, *a, *r) >= 0)  // pr and qr straddle line (pr)
    return o(*p, *a, *r) >= 0 && (o(*p, *r, *c) >= 0 || o(*q, *r, *c) >= 0);
  return false;  // ac separates
}

}  // namespace

// CGAL Triangle_3_Triangle_3_do_intersect.h, do_intersect_coplanar.
bool FilteredPredicates::coplanar_triangles_intersect(const Vec3d& P, const Vec3d& Q, const Vec3d& R, const Vec3d& A,
                                                      const Vec3d& B, const Vec3d& C) const {
  const int ax = plane_axis(P, Q, R);
  auto o = [&](const Vec3d& x, const Vec3d& y, const Vec3d& z) { return orient2d(x, y, z, ax); };
  const Vec3d *p = &P, *q = &Q, *r = &R, *a = &A, *b = &B, *c = &C;
  // Both triangles counter-clockwise.
  if (o(P, Q, R) < 0) std::swap(q, r);
  if (o(A, B, C) < 0) std::swap(b, c);
  // Where p lies in the arrangement of the lines through abc's edges.
  if (o(*a, *b, *p) >= 0) {
    if (o(*b, *c, *p) >= 0) {
      if (o(*c, *a, *p) >= 0) return true;  // p inside abc
      return test_edge(p, q, r, a, c, o);   // p sees ac
    }
    if (o(*c, *a, *p) >= 0) return test_edge(p, q, r, c, b, o);  // p sees bc
    return test_vertex(p, q, r, a, b, c, o);                     // p sees c
  }
  if (o(*b, *c, *p) >= 0) {
    if (o(*c, *a, *p) >= 0) return test_edge(p, q, r, b, a, o);  // p sees ab
    return test_vertex(p, q, r, b, c, a, o);                     // p sees a
  }
  return test_vertex(p, q, r, c, a, b, o);  // p sees b
}

// CGAL Segment_3_Triangle_3_do_intersect.h, do_intersect_coplanar(A, B, C, p, q).
bool FilteredPredicates::coplanar_segment_triangle_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& A,
                                                             const Vec3d& B, const Vec3d& C) const {
  const int ax = plane_axis(A, B, C);
  auto o = [&](const Vec3d& x, const Vec3d& y, const Vec3d& z) { return orient2d(x, y, z, ax); };
  const Vec3d *a = &A, *b = &B, *c = &C;
  if (o(A, B, C) <= 0) std::swap(b, c);  // counter-clockwise
  // The segment's supporting line against the triangle.
  const int pqa = o(p, q, *a), pqb = o(p, q, *b), pqc = o(p, q, *c);
  if (pqa > 0) {
    if (pqb > 0) {
      if (pqc > 0) return false;
      return o(*b, *c, q) >= 0 && o(*c, *a, p) >= 0;  // c isolated on the negative side
    }
    if (pqb < 0) {
      if (pqc > 0) return o(*a, *b, q) >= 0 && o(*b, *c, p) >= 0;  // b isolated on the negative side
      return o(*a, *b, q) >= 0 && o(*c, *a, p) >= 0;               // a isolated on the positive side
    }
    if (pqc > 0) return o(*a, *b, q) >= 0 && o(*b, *c, p) >= 0;
    return o(*a, *b, q) >= 0 && o(*c, *a, p) >= 0;
  }
  if (pqa < 0) {
    if (pqb > 0) {
      if (pqc > 0) return o(*a, *b, p) >= 0 && o(*c, *a, q) >= 0;  // a isolated on the negative side
      return o(*a, *b, p) >= 0 && o(*b, *c, q) >= 0;               // b isolated on the positive side
    }
    if (pqb < 0) {
      if (pqc < 0) return false;
      return o(*b, *c, p) >= 0 && o(*c, *a, q) >= 0;  // c isolated on the positive side
    }
    if (pqc < 0) return o(*a, *b, p) >= 0 && o(*b, *c, q) >= 0;
    return o(*a, *b, p) >= 0 && o(*c, *a, q) >= 0;
  }
  if (pqb > 0) {
    if (pqc > 0) return o(*a, *b, p) >= 0 && o(*c, *a, q) >= 0;
    return o(*a, *b, p) >= 0 && o(*b, *c, q) >= 0;
  }
  if (pqb < 0) {
    if (pqc < 0) return o(*a, *b, q) >= 0 && o(*c, *a, p) >= 0;
    return o(*a, *b, q) >= 0 && o(*b, *c, p) >= 0;
  }
  if (pqc > 0) return o(*b, *c, p) >= 0 && o(*c, *a, q) >= 0;
  return o(*b, *c, q) >= 0 && o(*c, *a, p) >= 0;
}

// CGAL Segment_3_Triangle_3_do_intersect.h, do_intersect(Triangle_3, Segment_3).
bool FilteredPredicates::segment_triangle_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                                                    const Vec3d& c) const {
  const int abcp = orientation(a, b, c, p);
  const int abcq = orientation(a, b, c, q);
  // p sees the triangle counter-clockwise (or q, with the roles swapped).
  auto sees = [&](const Vec3d& s, const Vec3d& t) {
    return orientation(s, t, a, b) <= 0 && orientation(s, t, b, c) <= 0 && orientation(s, t, c, a) <= 0;
  };
  if (abcp > 0) {
    if (abcq > 0) return false;  // both in the open positive half-space
    return sees(p, q);
  }
  if (abcp < 0) {
    if (abcq < 0) return false;
    return sees(q, p);
  }
  if (abcq > 0) return sees(q, p);
  if (abcq < 0) return sees(p, q);
  return coplanar_segment_triangle_intersect(p, q, a, b, c);
}

// CGAL Triangle_3_Triangle_3_do_intersect.h, do_intersect(Triangle_3, Triangle_3).
bool FilteredPredicates::triangles_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& r, const Vec3d& a,
                                             const Vec3d& b, const Vec3d& c) const {
  // Distance signs of p, q, r to the plane of (a, b, c); s/t pick the edges of pqr that
  // cross it, in the order the final interval test needs.
  const Vec3d *s_min1, *t_min1, *s_max1, *t_max1;
  {
    const int dp = orientation(a, b, c, p), dq = orientation(a, b, c, q), dr = orientation(a, b, c, r);
    if (dp > 0) {
      if (dq > 0) {
        if (dr > 0) return false;
        s_min1 = &q; t_min1 = &r; s_max1 = &r; t_max1 = &p;  // r isolated on the negative side
      } else if (dr > 0) {
        s_min1 = &p; t_min1 = &q; s_max1 = &q; t_max1 = &r;  // q isolated on the negative side
      } else {
        s_min1 = &p; t_min1 = &q; s_max1 = &r; t_max1 = &p;  // p isolated on the positive side
      }
    } else if (dp < 0) {
      if (dq < 0) {
        if (dr < 0) return false;
        s_min1 = &r; t_min1 = &p; s_max1 = &q; t_max1 = &r;  // r isolated on the positive side
      } else if (dr < 0) {
        s_min1 = &q; t_min1 = &r; s_max1 = &p; t_max1 = &q;  // q isolated on the positive side
      } else {
        s_min1 = &r; t_min1 = &p; s_max1 = &p; t_max1 = &q;  // p isolated on the negative side
      }
    } else if (dq > 0) {
      if (dr > 0) {
        s_min1 = &r; t_min1 = &p; s_max1 = &p; t_max1 = &q;  // p isolated on the negative side
      } else {
        s_min1 = &q; t_min1 = &r; s_max1 = &p; t_max1 = &q;  // q isolated on the positive side
      }
    } else if (dq < 0) {
      if (dr < 0) {
        s_min1 = &p; t_min1 = &q; s_max1 = &r; t_max1 = &p;  // p isolated on the positive side
      } else {
        s_min1 = &p; t_min1 = &q; s_max1 = &q; t_max1 = &r;  // q isolated on the negative side
      }
    } else if (dr > 0) {
      s_min1 = &r; t_min1 = &p; s_max1 = &q; t_max1 = &r;  // r isolated on the positive side
    } else if (dr < 0) {
      s_min1 = &q; t_min1 = &r; s_max1 = &r; t_max1 = &p;  // r isolated on the negative side
    } else {
      return coplanar_triangles_intersect(p, q, r, a, b, c);
    }
  }
  const Vec3d *s_min2, *t_min2, *s_max2, *t_max2;
  {
    const int da = orientation(p, q, r, a), db = orientation(p, q, r, b), dc = orientation(p, q, r, c);
    if (da > 0) {
      if (db > 0) {
        if (dc > 0) return false;
        s_min2 = &b; t_min2 = &c; s_max2 = &c; t_max2 = &a;
      } else if (dc > 0) {
        s_min2 = &a; t_min2 = &b; s_max2 = &b; t_max2 = &c;
      } else {
        s_min2 = &a; t_min2 = &b; s_max2 = &c; t_max2 = &a;
      }
    } else if (da < 0) {
      if (db < 0) {
        if (dc < 0) return false;
        s_min2 = &c; t_min2 = &a; s_max2 = &b; t_max2 = &c;
      } else if (dc < 0) {
        s_min2 = &b; t_min2 = &c; s_max2 = &a; t_max2 = &b;
      } else {
        s_min2 = &c; t_min2 = &a; s_max2 = &a; t_max2 = &b;
      }
    } else if (db > 0) {
      if (dc > 0) {
        s_min2 = &c; t_min2 = &a; s_max2 = &a; t_max2 = &b;
      } else {
        s_min2 = &b; t_min2 = &c; s_max2 = &a; t_max2 = &b;
      }
    } else if (db < 0) {
      if (dc < 0) {
        s_min2 = &a; t_min2 = &b; s_max2 = &c; t_max2 = &a;
      } else {
        s_min2 = &a; t_min2 = &b; s_max2 = &b; t_max2 = &c;
      }
    } else if (dc > 0) {
      s_min2 = &c; t_min2 = &a; s_max2 = &b; t_max2 = &c;
    } else if (dc < 0) {
      s_min2 = &b; t_min2 = &c; s_max2 = &c; t_max2 = &a;
    } else {
      return coplanar_triangles_intersect(p, q, r, a, b, c);  // unreachable for non-flat triangles
    }
  }
  // The two intervals on the line where the planes meet overlap.
  return orientation(*s_min1, *t_min1, *s_min2, *t_min2) <= 0 && orientation(*s_max1, *t_max1, *t_max2, *s_max2) <= 0;
}

}  // namespace visgate::mesh
