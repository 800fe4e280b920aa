#include "mmba/geodesy/crs.h"

#include <cmath>
#include <cstdio>
#include <utility>

#include <proj.h>

#include "mmba/core/error.h"

namespace mmba::geodesy {

namespace {

// Owns one PJ*.
struct PjDeleter {
  void operator()(PJ* pj) const { proj_destroy(pj); }
};
using PjPtr = std::unique_ptr<PJ, PjDeleter>;

std::string ContextError(PJ_CONTEXT* ctx) {
  const int code = proj_context_errno(ctx);
  return code == 0 ? std::string("PROJ gave no reason") : proj_context_errno_string(ctx, code);
}

// "AUTH:CODE" of an object, or "".
std::string AuthorityId(const PJ* pj) {
  const char* auth = proj_get_id_auth_name(pj, 0);
  const char* code = proj_get_id_code(pj, 0);
  return auth && code ? std::string(auth) + ":" + code : std::string();
}

int AxisCount(PJ_CONTEXT* ctx, const PJ* crs) {
  PjPtr cs(proj_crs_get_coordinate_system(ctx, crs));
  return cs ? proj_cs_get_axis_count(ctx, cs.get()) : 0;
}

}  // namespace

std::string HeightKindName(HeightKind kind) {
  switch (kind) {
    case HeightKind::kEllipsoidal: return "ellipsoidal";
    case HeightKind::kOrthometric: return "orthometric";
    case HeightKind::kAsGiven: return "as given";
  }
  return "as given";
}

struct Crs::Impl {
  PJ_CONTEXT* ctx = nullptr;
  PjPtr crs;             // as given (a BoundCRS unwrapped to its source)
  PjPtr horizontal_part; // the horizontal component of a compound CRS, or null
  const PJ* horizontal = nullptr;  // crs or horizontal_part
  PjPtr to_geodetic;     // horizontal CRS → its own geographic CRS, normalised axis order
  PjPtr projection;      // the projection as a classic PROJ operation (radians in), for proj_factors
  PjPtr geoid;           // +proj=vgridshift (H → h), or null
  std::string definition, where, identifier, name, wkt, wkt1, geoid_grid;
  HeightKind height_kind = HeightKind::kAsGiven;
  bool is_geographic = false;
  Ellipsoid ellipsoid;

  ~Impl() {
    geoid.reset();
    to_geodetic.reset();
    crs.reset();
    projection.reset();
    horizontal_part.reset();
    if (ctx) proj_context_destroy(ctx);
  }

  [[noreturn]] void Fail(const std::string& message) const {
    throw InputError::Message(where, message);
  }

  void Parse();
  const PJ* Horizontal(PjPtr* holder);
  void SetEllipsoid(const PJ* geodetic_crs);
  void SetIdentity(const PJ* horizontal);
  void OpenGeoid();
  void OpenProjection();
};

// The horizontal CRS's PROJ.4 string without +type=crs: an operation from geodetic radians to
// the grid in its own unit, without the EPSG axis order (as pyproj's Proj is built).
void Crs::Impl::OpenProjection() {
  const char* text = proj_as_proj_string(ctx, horizontal, PJ_PROJ_4, nullptr);
  if (!text) return;
  std::string projection_string = text;
  const size_t type = projection_string.find("+type=crs");
  if (type != std::string::npos) projection_string.erase(type, 9);
  projection.reset(proj_create(ctx, projection_string.c_str()));
}

void Crs::Impl::Parse() {
  crs.reset(proj_create(ctx, definition.c_str()));
  if (!crs || !proj_is_crs(crs.get())) {
    std::string reason = crs ? std::string("not a CRS") : ContextError(ctx);
    if (reason.rfind("Unknown error", 0) == 0) {  // PROJ 9.1 names no reason for an unknown code
      reason = definition.rfind("EPSG:", 0) == 0 ? "no such code in PROJ's EPSG database" : "PROJ cannot parse it";
    }
    Fail("'" + definition + "' is not a coordinate reference system PROJ knows (" + reason +
         "); expected e.g. EPSG:25832, EPSG:2154+5720 or a PROJ string with +type=crs");
  }
  if (proj_get_type(crs.get()) == PJ_TYPE_BOUND_CRS) {
    crs.reset(proj_get_source_crs(ctx, crs.get()));
  }
  const PJ_TYPE type = proj_get_type(crs.get());
  if (type == PJ_TYPE_GEOCENTRIC_CRS) {
    Fail("'" + definition + "' is a geocentric (ECEF) CRS; expected a projected or " +
         "geographic CRS, optionally compound with a vertical CRS");
  }
  if (type != PJ_TYPE_COMPOUND_CRS && type != PJ_TYPE_PROJECTED_CRS &&
      type != PJ_TYPE_GEOGRAPHIC_2D_CRS && type != PJ_TYPE_GEOGRAPHIC_3D_CRS) {
    Fail("'" + definition + "' is not a projected, geographic or compound CRS");
  }
  name = proj_get_name(crs.get());
  // proj_as_wkt's string lives until the next call on the object: copy each at once.
  const char* w2 = proj_as_wkt(ctx, crs.get(), PJ_WKT2_2019, nullptr);
  wkt = w2 ? w2 : "";
  const char* w1 = proj_as_wkt(ctx, crs.get(), PJ_WKT1_GDAL, nullptr);
  wkt1 = w1 ? w1 : "";
}

// The horizontal part: the first component of a compound CRS, otherwise the CRS itself.
const PJ* Crs::Impl::Horizontal(PjPtr* holder) {
  if (proj_get_type(crs.get()) != PJ_TYPE_COMPOUND_CRS) {
    const int axes = AxisCount(ctx, crs.get());
    height_kind = axes == 3 ? HeightKind::kEllipsoidal : HeightKind::kAsGiven;
    return crs.get();
  }
  holder->reset(proj_crs_get_sub_crs(ctx, crs.get(), 0));
  PjPtr vertical(proj_crs_get_sub_crs(ctx, crs.get(), 1));
  if (!*holder || !vertical || proj_get_type(vertical.get()) != PJ_TYPE_VERTICAL_CRS) {
    Fail("'" + definition + "' is a compound CRS without a horizontal and a vertical part");
  }
  height_kind = HeightKind::kOrthometric;
  return holder->get();
}

void Crs::Impl::SetEllipsoid(const PJ* geodetic_crs) {
  PjPtr ell(proj_get_ellipsoid(ctx, geodetic_crs));
  double a = 0, b = 0, inv_f = 0;
  int computed = 0;
  if (!ell || !proj_ellipsoid_get_parameters(ctx, ell.get(), &a, &b, &computed, &inv_f)) {
    Fail("'" + definition + "' has no ellipsoid PROJ can read");
  }
  ellipsoid.a_m = a;
  ellipsoid.f = inv_f > 0 ? 1.0 / inv_f : 0.0;
}

void Crs::Impl::SetIdentity(const PJ* horizontal) {
  is_geographic = proj_get_type(horizontal) == PJ_TYPE_GEOGRAPHIC_2D_CRS ||
                  proj_get_type(horizontal) == PJ_TYPE_GEOGRAPHIC_3D_CRS;
  identifier = AuthorityId(crs.get());
  if (identifier.empty() && proj_get_type(crs.get()) == PJ_TYPE_COMPOUND_CRS) {
    PjPtr vertical(proj_crs_get_sub_crs(ctx, crs.get(), 1));
    const std::string h = AuthorityId(horizontal), v = AuthorityId(vertical.get());
    if (!h.empty() && !v.empty() && h.substr(0, h.find(':')) == v.substr(0, v.find(':'))) {
      identifier = h + "+" + v.substr(v.find(':') + 1);
    }
  }
}

void Crs::Impl::OpenGeoid() {
  if (geoid_grid.empty()) return;
  const std::string pipeline =
      "+proj=vgridshift +grids=" + geoid_grid + " +multiplier=1";  // h = H + 1·N
  geoid.reset(proj_create(ctx, pipeline.c_str()));
  if (!geoid) {
    Fail("geoid grid '" + geoid_grid + "' cannot be opened by PROJ (" + ContextError(ctx) +
         "); expected a PROJ-readable grid (GTX, GeoTIFF) of geoid undulations in metres");
  }
}

Crs::Crs(const std::string& definition, const std::string& where, const std::string& geoid_grid)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.definition = definition;
  m.where = where;
  m.geoid_grid = geoid_grid;
  m.ctx = proj_context_create();
  proj_log_level(m.ctx, PJ_LOG_NONE);
  m.Parse();
  m.horizontal = m.Horizontal(&m.horizontal_part);
  const PJ* horizontal = m.horizontal;
  PjPtr geodetic(proj_crs_get_geodetic_crs(m.ctx, horizontal));
  if (!geodetic) m.Fail("'" + definition + "' has no geodetic datum PROJ can read");
  m.SetEllipsoid(geodetic.get());
  m.SetIdentity(horizontal);
  PjPtr op(proj_create_crs_to_crs_from_pj(m.ctx, horizontal, geodetic.get(), nullptr, nullptr));
  if (op) m.to_geodetic.reset(proj_normalize_for_visualization(m.ctx, op.get()));
  if (!m.to_geodetic) {
    m.Fail("'" + definition + "': PROJ finds no conversion to its geodetic CRS (" +
           ContextError(m.ctx) + ")");
  }
  if (!m.is_geographic) m.OpenProjection();
  if (!geoid_grid.empty() && m.height_kind == HeightKind::kEllipsoidal) {
    m.Fail("a geoid grid is given, but '" + definition + "' has ellipsoidal heights; a grid " +
           "needs orthometric heights (a compound CRS such as EPSG:25832+7837) or a 2-D CRS");
  }
  if (!geoid_grid.empty() && m.height_kind == HeightKind::kAsGiven) {
    m.height_kind = HeightKind::kOrthometric;
  }
  m.OpenGeoid();
}

Crs::~Crs() = default;
Crs::Crs(Crs&&) noexcept = default;
Crs& Crs::operator=(Crs&&) noexcept = default;

const std::string& Crs::definition() const { return impl_->definition; }
const std::string& Crs::identifier() const { return impl_->identifier; }
const std::string& Crs::name() const { return impl_->name; }
const std::string& Crs::wkt() const { return impl_->wkt; }
const std::string& Crs::wkt1() const { return impl_->wkt1; }
HeightKind Crs::height_kind() const { return impl_->height_kind; }
bool Crs::is_geographic() const { return impl_->is_geographic; }
const Ellipsoid& Crs::ellipsoid() const { return impl_->ellipsoid; }
const std::string& Crs::geoid_grid() const { return impl_->geoid_grid; }

namespace {
bool Finite(const PJ_COORD& c) {
  return std::isfinite(c.xyz.x) && std::isfinite(c.xyz.y) && std::isfinite(c.xyz.z) &&
         std::fabs(c.xyz.x) < 1e300 && std::fabs(c.xyz.y) < 1e300;
}
std::string Triple(double x, double y, double z) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "(%.4f, %.4f, %.4f)", x, y, z);
  return buf;
}
}  // namespace

Geodetic Crs::GeodeticFromCrs(const Eigen::Vector3d& xyz) const {
  const Impl& m = *impl_;
  PJ_COORD c = proj_coord(xyz.x(), xyz.y(), xyz.z(), 0);
  PJ_COORD g = proj_trans(m.to_geodetic.get(), PJ_FWD, c);
  if (!Finite(g)) {
    m.Fail("coordinate " + Triple(xyz.x(), xyz.y(), xyz.z()) + " is outside the domain of " +
           m.name + " (" + m.definition + ")");
  }
  Geodetic out{g.xyz.y, g.xyz.x, xyz.z()};
  if (m.geoid) {
    PJ_COORD r = proj_coord(proj_torad(g.xyz.x), proj_torad(g.xyz.y), xyz.z(), 0);
    PJ_COORD h = proj_trans(m.geoid.get(), PJ_FWD, r);
    if (!Finite(h)) {
      m.Fail("coordinate " + Triple(xyz.x(), xyz.y(), xyz.z()) + " is outside the geoid grid '" +
             m.geoid_grid + "'");
    }
    out.height_m = h.xyz.z;
  }
  return out;
}

Eigen::Vector3d Crs::CrsFromGeodetic(const Geodetic& geodetic) const {
  const Impl& m = *impl_;
  double height = geodetic.height_m;
  if (m.geoid) {
    PJ_COORD r = proj_coord(proj_torad(geodetic.longitude_deg),
                            proj_torad(geodetic.latitude_deg), geodetic.height_m, 0);
    PJ_COORD h = proj_trans(m.geoid.get(), PJ_INV, r);
    if (!Finite(h)) {
      m.Fail("latitude/longitude " + Triple(geodetic.latitude_deg, geodetic.longitude_deg, 0) +
             " is outside the geoid grid '" + m.geoid_grid + "'");
    }
    height = h.xyz.z;
  }
  PJ_COORD c = proj_coord(geodetic.longitude_deg, geodetic.latitude_deg, height, 0);
  PJ_COORD p = proj_trans(m.to_geodetic.get(), PJ_INV, c);
  if (!Finite(p)) {
    m.Fail("latitude/longitude " + Triple(geodetic.latitude_deg, geodetic.longitude_deg, 0) +
           " is outside the domain of " + m.name);
  }
  return {p.xyz.x, p.xyz.y, height};
}

GridFactors Crs::Factors(const Geodetic& geodetic) const {
  const Impl& m = *impl_;
  GridFactors out;
  if (m.is_geographic || !m.projection) return out;
  const PJ_COORD lp = proj_coord(proj_torad(geodetic.longitude_deg),
                                 proj_torad(geodetic.latitude_deg), 0, 0);
  const PJ_FACTORS f = proj_factors(m.projection.get(), lp);
  if (!(f.meridional_scale > 0) || !std::isfinite(f.meridian_convergence)) {
    m.Fail("latitude/longitude " + Triple(geodetic.latitude_deg, geodetic.longitude_deg, 0) +
           ": PROJ gives no scale factor of " + m.name + " there");
  }
  out.point_scale = f.meridional_scale;
  out.convergence_deg = proj_todeg(f.meridian_convergence);
  return out;
}

}  // namespace mmba::geodesy
