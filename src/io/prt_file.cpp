// .prt files (prt_file.h).
#include "polyrad/io/prt_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

#include "polyrad/geometry/mesher.h"
#include "polyrad/io/serialize.h"
#include "polyrad/scene/scene.h"
#include "polyrad/util/files.h"
#include "polyrad/util/hash.h"
#include "polyrad/util/json.h"

namespace polyrad {

namespace {

constexpr char kMagic[8] = {'P', 'O', 'L', 'Y', 'R', 'A', 'D', 'Q'};
constexpr std::size_t kAlign = 64;

std::size_t aligned(std::size_t n) { return (n + kAlign - 1) / kAlign * kAlign; }

struct Section {
  std::string name;
  std::size_t offset = 0, size = 0;
};

std::string header_json(const SeriesOperator& q, const std::vector<Section>& sections) {
  JsonWriter w;
  w.begin_object();
  w.value("format", "polyrad series operator");
  write_operator_metadata(w, q);
  w.value("layout", q.dense() ? "dense" : "sparse");
  w.value("rows", static_cast<long long>(q.rows()));
  w.value("nnz", static_cast<long long>(q.nnz()));
  w.value("num_patches", q.layout.num_patches);
  w.value("links", static_cast<long long>(q.layout.links.size()));
  if (q.direct) {
    const MeshDirect& d = *q.direct;
    w.begin_object("mesh_direct").value("objects", d.objects);
    w.value("link_rows", static_cast<long long>(d.link_value.size() / std::max(1, d.objects)));
    w.value("link_table", d.has_links()).value("mirrored", !d.mirrored.empty()).end_object();
  }
  w.begin_array("sections");
  for (const auto& s : sections)
    w.begin_object()
        .value("name", s.name)
        .value("offset", s.offset)
        .value("size", s.size)
        .end_object();
  w.end_array();
  w.end_object();
  return w.str();
}

// Assembles the whole file in memory: small enough for the scenes polyrad targets, and the
// checksum is then one pass.
std::string encode(const SeriesOperator& q) {
  const std::size_t value_size = q.precision == ValuePrecision::kFloat ? 4 : 2;
  struct Blob {
    const char* name;
    const void* data;
    std::size_t size;
  };
  std::vector<std::uint32_t> link_pairs;
  for (const auto& l : q.layout.links) {
    link_pairs.push_back(static_cast<std::uint32_t>(l.from));
    link_pairs.push_back(static_cast<std::uint32_t>(l.to));
  }
  std::vector<Blob> blobs;
  if (!q.dense()) {
    blobs.push_back(
        {"row_start", q.start(), sizeof(std::int64_t) * static_cast<std::size_t>(q.rows() + 1)});
    blobs.push_back(
        {"column", q.column(), sizeof(std::uint32_t) * static_cast<std::size_t>(q.nnz())});
  }
  blobs.push_back({"values", q.values(), 3 * value_size * static_cast<std::size_t>(q.nnz())});
  blobs.push_back({"links", link_pairs.data(), sizeof(std::uint32_t) * link_pairs.size()});
  blobs.push_back(
      {"flux_weight", q.layout.flux_weight.data(), sizeof(double) * q.layout.flux_weight.size()});
  if (q.direct) {
    const MeshDirect& d = *q.direct;
    auto add = [&](const char* name, const auto& v) {
      blobs.push_back({name, v.data(), sizeof(v[0]) * v.size()});
    };
    add("direct_column", d.column);
    add("direct_value", d.value);
    add("direct_link_row", d.link_row);
    add("direct_link_value", d.link_value);
    add("direct_mirrored", d.mirrored);
  }
  // The header holds the section table, whose offsets depend on the header's length: iterate
  // until the length settles (digits only grow, so this ends).
  std::vector<Section> sections(blobs.size());
  std::string header;
  std::size_t body = 0;
  for (int pass = 0; pass < 8; ++pass) {
    body = aligned(16 + header.size());
    std::size_t at = body;
    for (size_t b = 0; b < blobs.size(); ++b) {
      sections[b] = {blobs[b].name, at, blobs[b].size};
      at = aligned(at + blobs[b].size);
    }
    std::string next = header_json(q, sections);
    if (next.size() == header.size()) {
      header = next;
      break;
    }
    header = next;
  }
  std::size_t end = sections.back().offset + sections.back().size;
  std::string bytes(aligned(end) + 8, '\0');
  std::memcpy(&bytes[0], kMagic, 8);
  std::uint32_t version = kPrtVersion, header_length = static_cast<std::uint32_t>(header.size());
  std::memcpy(&bytes[8], &version, 4);
  std::memcpy(&bytes[12], &header_length, 4);
  std::memcpy(&bytes[16], header.data(), header.size());
  for (size_t b = 0; b < blobs.size(); ++b)
    if (blobs[b].size) std::memcpy(&bytes[sections[b].offset], blobs[b].data, blobs[b].size);
  std::uint64_t sum = checksum64(bytes.data(), bytes.size() - 8);
  std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
  return bytes;
}

[[noreturn]] void refuse(const std::string& name, const std::string& why) {
  throw InputError(SourceLocation{name}, "not a usable polyrad operator file: " + why);
}

const JsonValue& member(const JsonValue& v, const char* key, JsonValue::Kind kind,
                        const std::string& name) {
  const JsonValue* m = v.is(JsonValue::Kind::kObject) ? v.find(key) : nullptr;
  if (!m || !m->is(kind))
    refuse(name, std::string("header field '") + key + "' is missing or malformed");
  return *m;
}

double number(const JsonValue& v, const char* key, const std::string& name) {
  return member(v, key, JsonValue::Kind::kNumber, name).number;
}

std::int64_t count(const JsonValue& v, const char* key, const std::string& name, double limit) {
  double x = number(v, key, name);
  if (!(x >= 0.0 && x <= limit && x == std::floor(x)))
    refuse(name, std::string("header field '") + key + "' is out of range");
  return static_cast<std::int64_t>(x);
}

}  // namespace

void write_prt(const SeriesOperator& q, const std::string& path) {
  write_file_atomic(path, encode(q));
}

// The mesh's direct light a solution operator's gather reads (SeriesOperator::direct), checked
// so that every index it holds is safe to follow: one object per emitting object of the columns,
// columns are patches, link rows below their count, no section larger than the file. The values
// are copied out (12 bytes a patch and emitting object). A solution operator written before
// polyrad kept it has none: its relight draws no mirror images, as when it was written
// (Relighter::missing_images says so).
template <typename SectionFn>
std::shared_ptr<const MeshDirect> read_mesh_direct(const JsonValue& h, const SeriesOperator& q,
                                                   SectionFn& section, const std::string& name,
                                                   double file_size) {
  if (q.output != SeriesOutput::kSolution) refuse(name, "view rows keep no mesh's direct light");
  const JsonValue& m = member(h, "mesh_direct", JsonValue::Kind::kObject, name);
  const UnknownLayout& layout = q.layout;
  const std::int64_t b = layout.num_patches, links = static_cast<std::int64_t>(layout.links.size());
  auto d = std::make_shared<MeshDirect>();
  d->objects = static_cast<int>(count(m, "objects", name, static_cast<double>(b)));
  std::set<std::string> emitting;
  for (const SeriesColumn& c : q.columns) emitting.insert(c.object);
  if (static_cast<std::size_t>(d->objects) != emitting.size())
    refuse(name, "the mesh's direct light is not of the operator's emitting objects");
  const std::int64_t rows = count(m, "link_rows", name, static_cast<double>(links));
  const bool table = member(m, "link_table", JsonValue::Kind::kBool, name).boolean;
  const bool mirrored = member(m, "mirrored", JsonValue::Kind::kBool, name).boolean;
  if (!table && (rows > 0 || mirrored))
    refuse(name, "the mesh's direct light lacks its link table");
  const auto n = static_cast<std::size_t>(d->objects);
  auto read = [&](const char* key, auto& v, std::size_t count) {
    if (static_cast<double>(count) * sizeof(v[0]) > file_size)
      refuse(name, std::string("section '") + key + "' would be larger than the file");
    const auto* at = section(key, sizeof(v[0]) * count);
    v.resize(count);
    if (count) std::memcpy(v.data(), at, sizeof(v[0]) * count);
  };
  read("direct_column", d->column, n);
  read("direct_value", d->value, static_cast<std::size_t>(b) * n);
  read("direct_link_row", d->link_row, table ? static_cast<std::size_t>(links) : 0);
  read("direct_link_value", d->link_value, static_cast<std::size_t>(rows) * n);
  read("direct_mirrored", d->mirrored, mirrored ? static_cast<std::size_t>(b) * n : 0);
  for (std::int32_t c : d->column)
    if (c < 0 || c >= b) refuse(name, "the mesh's direct light names a patch out of range");
  for (std::int32_t r : d->link_row)
    if (r < -1 || r >= rows) refuse(name, "the mesh's direct light names a link row out of range");
  return d;
}

SeriesOperator read_prt_bytes(const void* data, std::size_t size, const std::string& name) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  if (reinterpret_cast<std::uintptr_t>(data) % 8 != 0)
    throw std::invalid_argument("read_prt_bytes needs 8-byte aligned data");
  if (size < 24) refuse(name, "the file is too short (truncated?)");
  if (std::memcmp(bytes, kMagic, 8) != 0) refuse(name, "wrong magic number (not a .prt file)");
  std::uint32_t version, header_length;
  std::memcpy(&version, bytes + 8, 4);
  std::memcpy(&header_length, bytes + 12, 4);
  if (version != kPrtVersion)
    refuse(name, "format version " + std::to_string(version) + ", this polyrad reads version " +
                     std::to_string(kPrtVersion));
  if (16 + static_cast<std::size_t>(header_length) + 8 > size)
    refuse(name, "the file is truncated");
  std::uint64_t stored;
  std::memcpy(&stored, bytes + size - 8, 8);
  if (stored != checksum64(bytes, size - 8))
    refuse(name, "checksum mismatch (corrupted or truncated)");

  JsonValue h;
  try {
    h = parse_json(std::string_view(reinterpret_cast<const char*>(bytes + 16), header_length),
                   name);
  } catch (const InputError& e) {
    refuse(name, std::string("the header is not valid JSON: ") + e.message());
  }
  SeriesOperator q;
  const std::string& layout = member(h, "layout", JsonValue::Kind::kString, name).string;
  if (layout != "dense" && layout != "sparse") refuse(name, "unknown layout '" + layout + "'");
  const bool dense = layout == "dense";
  const double limit = static_cast<double>(size);
  const std::int64_t rows = count(h, "rows", name, limit);
  const std::int64_t nnz = count(h, "nnz", name, limit);
  // Patch indices are ints, and link_start has num_patches + 1 entries: however large the file,
  // the count must leave room for that one more in an int.
  q.layout.num_patches =
      static_cast<int>(count(h, "num_patches", name, std::min(limit, 2147483646.0)));
  const std::int64_t links = count(h, "links", name, limit);
  try {
    read_operator_metadata(h, q.layout.num_patches, q);
  } catch (const InputError& e) {
    refuse(name, "the header: " + e.message());
  }
  if (q.output == SeriesOutput::kView && rows != static_cast<std::int64_t>(q.width) * q.height)
    refuse(name, "rows do not match the image size");
  if (q.columns.empty() || q.columns.size() > (1ull << 31))
    refuse(name, "the operator has no columns");

  // Sections: in bounds, aligned, of the sizes the counts imply.
  const std::size_t value_size = q.precision == ValuePrecision::kFloat ? 4 : 2;
  const std::size_t data_end = size - 8;
  auto section = [&](const char* key, std::size_t expect) -> const unsigned char* {
    for (const auto& s : member(h, "sections", JsonValue::Kind::kArray, name).array) {
      if (!s.is(JsonValue::Kind::kObject) ||
          member(s, "name", JsonValue::Kind::kString, name).string != key)
        continue;
      std::size_t offset = static_cast<std::size_t>(count(s, "offset", name, limit));
      std::size_t length = static_cast<std::size_t>(count(s, "size", name, limit));
      if (length != expect) refuse(name, std::string("section '") + key + "' has the wrong size");
      if (offset % kAlign != 0 || offset < 16 + header_length || offset > data_end ||
          length > data_end - offset)
        refuse(name, std::string("section '") + key + "' lies outside the file");
      return bytes + offset;
    }
    refuse(name, std::string("section '") + key + "' is missing");
  };
  if (dense && nnz != rows * static_cast<std::int64_t>(q.columns.size()))
    refuse(name, "a dense operator must store rows x columns entries");
  const std::int64_t* start = nullptr;
  const std::uint32_t* column = nullptr;
  if (!dense) {
    start = reinterpret_cast<const std::int64_t*>(
        section("row_start", 8 * static_cast<std::size_t>(rows + 1)));
    column = reinterpret_cast<const std::uint32_t*>(
        section("column", 4 * static_cast<std::size_t>(nnz)));
  }
  const void* values = section("values", 3 * value_size * static_cast<std::size_t>(nnz));
  const auto* link_pairs =
      reinterpret_cast<const std::uint32_t*>(section("links", 8 * static_cast<std::size_t>(links)));
  const auto* flux = reinterpret_cast<const double*>(
      section("flux_weight", 8 * static_cast<std::size_t>(q.layout.num_patches + links)));
  // Indices must be safe to follow: rows non-decreasing up to nnz, columns below cols.
  if (!dense) {
    if (start[0] != 0 || start[rows] != nnz) refuse(name, "the row table is inconsistent");
    for (std::int64_t k = 0; k < rows; ++k)
      if (start[k + 1] < start[k]) refuse(name, "the row table is inconsistent");
    for (std::int64_t k = 0; k < nnz; ++k)
      if (column[k] >= q.columns.size()) refuse(name, "a column index is out of range");
  }
  q.layout.links.resize(links);
  q.layout.link_start.assign(q.layout.num_patches + 1, 0);
  for (std::int64_t l = 0; l < links; ++l) {
    // Range-check the stored u32 values before they become (signed) PatchIds: one of 2^31 or
    // more would turn negative, pass a signed `< num_patches` and index link_start before its
    // start.
    const auto patches = static_cast<std::uint32_t>(q.layout.num_patches);
    if (link_pairs[2 * l] >= patches || link_pairs[2 * l + 1] >= patches)
      refuse(name, "the link table is inconsistent");
    Link link{static_cast<PatchId>(link_pairs[2 * l]), static_cast<PatchId>(link_pairs[2 * l + 1])};
    if (l > 0 && (link.from < q.layout.links[l - 1].from ||
                  (link.from == q.layout.links[l - 1].from && link.to <= q.layout.links[l - 1].to)))
      refuse(name, "the link table is inconsistent");
    q.layout.links[l] = link;
    ++q.layout.link_start[link.from + 1];
  }
  for (int p = 0; p < q.layout.num_patches; ++p)
    q.layout.link_start[p + 1] += q.layout.link_start[p];
  q.layout.flux_weight.assign(flux, flux + q.layout.num_patches + links);
  if (q.output == SeriesOutput::kSolution && rows != q.layout.size())
    refuse(name, "rows do not match the unknowns");
  if (h.find("mesh_direct")) q.direct = read_mesh_direct(h, q, section, name, limit);
  q.report.nnz = nnz;
  q.set_view(rows, start, column, values, nullptr);
  q.report.bytes = q.bytes();
  return q;
}

namespace {

void check_against_scene(const SeriesOperator& q, const std::string& prt_name,
                         const std::string& scene_path) {
  const std::string path = scene_path.empty() ? q.scene_file : scene_path;
  Scene scene;
  try {
    scene = load_scene(path);
  } catch (const InputError& e) {
    throw InputError(SourceLocation{prt_name}, "cannot check the operator against its scene '" +
                                                   path + "' (" + e.message() +
                                                   "); pass --scene PATH if it moved");
  }
  if (scene.hash != q.scene_hash)
    throw InputError(
        SourceLocation{prt_name},
        "stale operator: the scene '" + path +
            "' has changed since it was precomputed (or it was built from another scene)");
  if (q.output != SeriesOutput::kSolution) return;
  // Solution rows are read through a gather of the scene meshed again: it must mesh into the
  // same patches.
  const double patches = count_patches(apply_overrides(std::move(scene), q.overrides));
  if (patches != q.layout.num_patches)
    throw InputError(SourceLocation{prt_name},
                     "the scene meshes into " + std::to_string(static_cast<long long>(patches)) +
                         " patches but the operator has " + std::to_string(q.layout.num_patches));
}

}  // namespace

SeriesOperator read_prt(const std::string& path, const PrtReadOptions& options) {
  int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0)
    throw InputError(SourceLocation{path},
                     std::string("cannot open the operator file: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size <= 0) {
    ::close(fd);
    throw InputError(SourceLocation{path}, "the operator file is empty or unreadable");
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED)
    throw InputError(SourceLocation{path},
                     std::string("cannot map the operator file: ") + std::strerror(errno));
  std::shared_ptr<const void> keep(map,
                                   [size](const void* p) { ::munmap(const_cast<void*>(p), size); });
  SeriesOperator q = read_prt_bytes(map, size, path);
  q.set_view(q.rows(), q.start(), q.column(), q.values(), keep);
  if (options.check_scene) {
    check_against_scene(q, path, options.scene);
    if (!options.scene.empty()) q.scene_file = options.scene;
  }
  return q;
}

}  // namespace polyrad
