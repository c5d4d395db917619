// Triangle quadtree geometry: the nets of hierarchy/tri_polyhedron.h fold
// into the solids, the triangles of every level tile the solid, and point
// location inverts the projection.
#include "hierarchy/tri_geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "tests/hierarchy/tri_reference.h"

namespace simplexdb {
namespace {

using testing::AllCodesAtLevel;
using testing::AllPolyhedra;
using testing::RandomCode;
using testing::SolidPoint;
using testing::SolidVertices;

template <class Tag>
class TriGeometryTest : public testing::TriFixture<Tag> {};
TYPED_TEST_SUITE(TriGeometryTest, AllPolyhedra);

Vec3 Sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double Dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }

// (apex, left, right) x outward: positive when counterclockwise seen from
// outside. Returns the signed area.
double SignedArea(const TriPoints& t) {
  const Vec3 n = Cross(Sub(t[1], t[0]), Sub(t[2], t[0]));
  const Vec3 c = {t[0][0] + t[1][0] + t[2][0], t[0][1] + t[1][1] + t[2][1],
                  t[0][2] + t[1][2] + t[2][2]};
  return std::copysign(Norm(n) / 2, Dot(n, c));
}

// The base faces are regular, inscribed in the unit sphere, all of one edge
// length, and turn counterclockwise from outside exactly when the seed's net
// draws them tip-up (so left is west of right on faces 0-4 of Fig. 5).
TYPED_TEST(TriGeometryTest, BaseFacesAreRegularAndOrientedAsTheNet) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  const TriPoints f0 = PolyhedronVertices(Code::Face(0));
  const double edge = Norm(Sub(f0[1], f0[0]));
  for (int f = 0; f < Code::kFaces; ++f) {
    SCOPED_TRACE(f);
    const TriPoints t = PolyhedronVertices(Code::Face(f));
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(Norm(t[i]), 1.0, 1e-15);
      EXPECT_NEAR(Norm(Sub(t[i], t[(i + 1) % 3])), edge, 1e-14);
    }
    EXPECT_EQ(SignedArea(t) > 0, FaceIsTipUp<P>(f));
  }
}

// Octahedron face 0 is (N, E0 at longitude 0, E1 at 90): its child 01
// (bottom-left) holds E0, child 11 (bottom-right) holds E1, child 00 (top)
// the pole, and the center child points down.
TEST(TriGeometry, ChildrenAreWhereFigure1PutsThem) {
  const OctaCode face = OctaCode::Face(0);
  const TriPoints t = PolyhedronVertices(face);
  EXPECT_EQ(PolyhedronVertices(face.child(0b00))[0], t[0]);
  EXPECT_EQ(PolyhedronVertices(face.child(0b01))[1], t[1]);
  EXPECT_EQ(PolyhedronVertices(face.child(0b11))[2], t[2]);
  EXPECT_EQ(t[1], (Vec3{1, 0, 0}));
  EXPECT_EQ(t[2], (Vec3{0, 1, 0}));
  const TriPoints center = PolyhedronVertices(face.child(0b10));
  EXPECT_LT(center[0][2], center[1][2]) << "the center's apex is its lowest point";
  EXPECT_LT(SignedArea(center), 0);
}

// For every level to 8: every triangle turns as its orientation says and
// the areas of each face's triangles sum to the face's; to level 6 (5 on
// the icosahedron, 82k triangles) also: every edge of the level's mesh is
// shared by exactly two triangles that run along it in opposite directions.
// Together: the level tiles the solid.
TYPED_TEST(TriGeometryTest, EveryLevelTilesTheSolid) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  const int edge_level = P == Polyhedron::kIcosahedron ? 5 : 6;
  const double face_area = std::abs(SignedArea(PolyhedronVertices(Code::Face(0))));
  for (int level = 0; level <= 8; ++level) {
    SCOPED_TRACE(level);
    std::map<std::pair<SolidPoint, SolidPoint>, int> directed;
    std::vector<double> area(Code::kFaces, 0.0);
    for (const Code c : AllCodesAtLevel<P>(level)) {
      auto v = SolidVertices(c);
      ASSERT_NE(v[0], v[1]);
      const double a = SignedArea(PolyhedronVertices(c));
      ASSERT_EQ(a > 0, FaceIsTipUp<P>(c.face()) != c.flipped()) << c;
      // Counterclockwise seen from outside: (apex, left, right) on tip-up
      // triangles, (apex, right, left) on tip-down ones.
      if (a < 0) std::swap(v[1], v[2]);
      if (level <= edge_level) {
        for (int i = 0; i < 3; ++i) ++directed[{v[i], v[(i + 1) % 3]}];
      }
      ASSERT_NEAR(std::abs(a), face_area / std::pow(4.0, level), 1e-12);
      area[c.face()] += std::abs(a);
    }
    for (const auto& [edge, count] : directed) {
      ASSERT_EQ(count, 1) << "an edge run twice the same way";
      ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << "an edge with one side";
    }
    if (level <= edge_level) {
      ASSERT_EQ(directed.size(), 3 * AllCodesAtLevel<P>(level).size());
    }
    for (int f = 0; f < Code::kFaces; ++f) EXPECT_NEAR(area[f], face_area, 1e-10);
  }
}

TYPED_TEST(TriGeometryTest, SphereVerticesAreTheProjection) {
  constexpr Polyhedron P = TestFixture::kSolid;
  std::mt19937_64 rng(3);
  for (int i = 0; i < 2000; ++i) {
    const auto c = RandomCode<P>(rng, static_cast<int>(rng() % (TriCode<P>::kMaxLevel + 1)));
    const TriPoints poly = PolyhedronVertices(c);
    const TriPoints sphere = SphereVertices(c);
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(Norm(sphere[k]), 1.0, 1e-15);
      ASSERT_NEAR(Norm(Cross(poly[k], sphere[k])), 0.0, 1e-15) << "on the same ray";
      ASSERT_GT(Dot(poly[k], sphere[k]), 0);
    }
  }
}

// The centroid of a triangle, projected to the sphere and written as
// latitude and longitude, locates that triangle again: every code up to
// level 5, random codes at every level to the maximum.
TYPED_TEST(TriGeometryTest, CentroidLatLngLocatesTheTriangle) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  std::vector<Code> codes;
  for (int level = 0; level <= 5; ++level) {
    for (const Code c : AllCodesAtLevel<P>(level)) codes.push_back(c);
  }
  std::mt19937_64 rng(5);
  for (int level = 0; level <= Code::kMaxLevel; ++level) {
    for (int i = 0; i < 3000; ++i) codes.push_back(RandomCode<P>(rng, level));
  }
  for (const Code c : codes) {
    const LatLng ll = PointToLatLng(SphereCentroid(c));
    ASSERT_EQ(LatLngToCode<P>(ll, c.level()), c) << ll.lat_degrees << "," << ll.lng_degrees;
    ASSERT_EQ(PointToCode<P>(SphereCentroid(c), c.level()), c);
  }
}

// A vertex of the solid locates to a triangle that has it as a corner, at
// every level: points on edges and corners go to a triangle holding them.
TYPED_TEST(TriGeometryTest, CornersLocateToATriangleHoldingThem) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  for (int f = 0; f < Code::kFaces; ++f) {
    for (int k = 0; k < 3; ++k) {
      const auto id = FaceVertexIds<P>(f)[k];
      SolidPoint corner{};
      corner[id] = kTriScale;
      for (int level : {0, 1, 7, Code::kMaxLevel}) {
        const Code c = PointToCode<P>(PolyhedronVertex<P>(id), level);
        const auto v = SolidVertices(c);
        EXPECT_TRUE(v[0] == corner || v[1] == corner || v[2] == corner) << c;
      }
    }
  }
}

TEST(TriGeometry, LatLngRoundTrips) {
  for (double lat = -89.5; lat < 90; lat += 7.25) {
    for (double lng = -179.5; lng < 180; lng += 11.5) {
      const LatLng back = PointToLatLng(LatLngToPoint({lat, lng}));
      EXPECT_NEAR(back.lat_degrees, lat, 1e-12);
      EXPECT_NEAR(back.lng_degrees, lng, 1e-12);
    }
  }
  // The north pole is the apex of icosahedron faces 0-4 and octahedron 0-3.
  EXPECT_LT(LatLngToCode<Polyhedron::kIcosahedron>({89.9, 10}, 3).face(), 5);
  EXPECT_EQ(LatLngToCode<Polyhedron::kIcosahedron>({89.9, 10}, 3).path(), 0u);
  EXPECT_EQ(LatLngToCode<Polyhedron::kOctahedron>({-45, 135}, 0).face(), 5);
}

}  // namespace
}  // namespace simplexdb
