// MERL table: index mapping against the reference reader's cases, file layout, lookup.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "paintlab/brdf/merl.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::brdf;
using ::testing::HasSubstr;

namespace {

struct CsvRow {
  double theta_in_deg, phi_in_deg, theta_out_deg, phi_out_deg;
  double theta_half, phi_half, theta_diff, phi_diff;
  long index;
  int ih, id, ip;
};

std::vector<CsvRow> read_reference_rows() {
  const auto path = test::data_dir() / "merl-reference/merl_index_vectors.csv";
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<CsvRow> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    for (char& ch : line)
      if (ch == ',') ch = ' ';
    std::istringstream s(line);
    CsvRow r{};
    s >> r.theta_in_deg >> r.phi_in_deg >> r.theta_out_deg >> r.phi_out_deg >> r.theta_half >> r.phi_half >>
        r.theta_diff >> r.phi_diff >> r.index >> r.ih >> r.id >> r.ip;
    EXPECT_FALSE(s.fail()) << line;
    rows.push_back(r);
  }
  return rows;
}

double rad(double deg) { return deg * std::numbers::pi / 180.0; }
}  // namespace

TEST(MerlIndex, ReproducesEveryReferenceRow) {
  const auto rows = read_reference_rows();
  ASSERT_EQ(rows.size(), 1215u);
  int mismatches = 0;
  for (const auto& r : rows) {
    const HalfDiff hd = half_diff_from_spherical(rad(r.theta_in_deg), rad(r.phi_in_deg), rad(r.theta_out_deg),
                                                 rad(r.phi_out_deg));
    const MerlBin b = merl_bin(hd);
    const std::string where = ::testing::PrintToString(std::vector<double>{r.theta_in_deg, r.phi_in_deg,
                                                                           r.theta_out_deg, r.phi_out_deg});
    EXPECT_NEAR(hd.theta_h, r.theta_half, 2e-9) << where;
    EXPECT_NEAR(hd.theta_d, r.theta_diff, 2e-9) << where;
    // The angles print with 9 decimals; compare phi only where it is well defined.
    if (hd.theta_h > 1e-6) {
      EXPECT_NEAR(std::remainder(hd.phi_h - r.phi_half, 2 * std::numbers::pi), 0.0, 2e-9) << where;
    }
    const bool same = b.theta_h == r.ih && b.theta_d == r.id && b.phi_d == r.ip &&
                      static_cast<long>(merl_flat_index(b)) == r.index;
    if (!same) {
      ++mismatches;
      ADD_FAILURE() << where << ": got (" << b.theta_h << ", " << b.theta_d << ", " << b.phi_d << ") phi_d "
                    << hd.phi_d << ", reference (" << r.ih << ", " << r.id << ", " << r.ip << ") phi_d " << r.phi_diff;
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(MerlIndex, FormulaOnKnownAngles) {
  // i = floor(sqrt(theta_h / (pi/2)) * 90): theta_h = (pi/2) / 4 -> sqrt = 0.5 -> 45.
  EXPECT_EQ(merl_theta_h_index(std::numbers::pi / 8 + 1e-12), 45);
  EXPECT_EQ(merl_theta_h_index(0.0), 0);
  EXPECT_EQ(merl_theta_h_index(-0.1), 0);
  EXPECT_EQ(merl_theta_h_index(std::numbers::pi / 2), 89);  // clamped
  EXPECT_EQ(merl_theta_d_index(std::numbers::pi / 4 + 1e-12), 45);
  EXPECT_EQ(merl_theta_d_index(2.0), 89);
  EXPECT_EQ(merl_phi_d_index(0.5 * std::numbers::pi + 1e-12), 90);
  EXPECT_EQ(merl_phi_d_index(-0.5 * std::numbers::pi + 1e-12), 90);  // phi_d and phi_d + pi share a bin
  EXPECT_EQ(merl_phi_d_index(std::numbers::pi), 179);                // clamped as in the reference
  EXPECT_EQ(merl_flat_index({1, 2, 3}), 3u + 180u * (2u + 90u * 1u));
  for (std::size_t flat : {std::size_t{0}, std::size_t{12345}, kMerlBins - 1}) {
    EXPECT_EQ(merl_flat_index(merl_bin_of_flat(flat)), flat);
    // A bin's centre falls into the bin.
    const Eigen::Vector3d c = merl_bin_centre(flat);
    EXPECT_EQ(merl_flat_index(merl_bin({c[0], 0, c[1], c[2]})), flat);
  }
}

namespace {
MerlTable random_table(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  MerlTable t;
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    if (b % 7 == 3) continue;  // some empty bins
    t.set_value(b, Rgb(10 * u(rng), 0.01 * u(rng), 1000 * u(rng)), BinState::Measured);
  }
  return t;
}
}  // namespace

TEST(MerlFile, WriteReadRoundTripIsExactToTheScale) {
  test::TempDir d;
  const MerlTable t = random_table(test::seed());
  write_merl(d / "t.binary", t);
  EXPECT_EQ(std::filesystem::file_size(d / "t.binary"), kMerlFileBytes);
  const MerlTable back = read_merl(d / "t.binary");
  std::size_t empties = 0;
  for (std::size_t b = 0; b < kMerlBins; b += 1) {
    ASSERT_EQ(back.state(b), t.state(b)) << b;
    if (t.state(b) == BinState::Empty) {
      ++empties;
      continue;
    }
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(back.value(b)[c], t.value(b)[c], 1e-15 * std::abs(t.value(b)[c]) + 1e-300);
  }
  EXPECT_EQ(empties, t.count_in_state(BinState::Empty));
  EXPECT_EQ(encode_merl(back), encode_merl(t));
}

TEST(MerlFile, LayoutIsChannelMajorWithReaderScales) {
  MerlTable t;
  const std::size_t bin = merl_flat_index({10, 20, 30});
  t.set_value(bin, Rgb(1.0, 2.0, 3.0), BinState::Measured);
  const std::string bytes = encode_merl(t);
  std::int32_t dims[3];
  std::memcpy(dims, bytes.data(), 12);
  EXPECT_EQ(dims[0], 90);
  EXPECT_EQ(dims[1], 90);
  EXPECT_EQ(dims[2], 180);
  auto stored = [&](int c, std::size_t b) {
    double v;
    std::memcpy(&v, bytes.data() + 12 + (c * kMerlBins + b) * 8, 8);
    return v;
  };
  EXPECT_DOUBLE_EQ(stored(0, bin), 1.0 * 1500.0);
  EXPECT_DOUBLE_EQ(stored(1, bin), 2.0 * 1500.0 / 1.15);
  EXPECT_DOUBLE_EQ(stored(2, bin), 3.0 * 1500.0 / 1.66);
  EXPECT_LT(stored(0, bin + 1), 0.0);  // empty: negative
  EXPECT_LT(stored(2, 0), 0.0);
}

TEST(MerlFile, NegativeMeansMissing) {
  MerlTable t;
  t.set_value(5, Rgb(1, 1, 1), BinState::Measured);
  std::string bytes = encode_merl(t);
  double neg = -0.5;
  std::memcpy(bytes.data() + 12 + (2 * kMerlBins + 5) * 8, &neg, 8);  // blue of bin 5
  const MerlTable back = decode_merl(bytes, "x.binary");
  EXPECT_EQ(back.state(5), BinState::Empty);
  EXPECT_EQ(back.count_in_state(BinState::Measured), 0u);
}

// A measured bin whose mean came out below zero in one channel (a binned session: noise about
// the black level, or the colour matrix on a tinted glint) stays measured through the file, at
// 0 in that channel, the others kept: the file's negative numbers mean missing, and a table
// `paintlab bin` wrote must read back with the states its coverage map records.
TEST(MerlFile, AMeasuredNegativeMeanIsWrittenAsZeroAndStaysMeasured) {
  MerlTable t;
  const std::size_t bin = merl_flat_index({40, 30, 20});
  t.set_value(bin, Rgb(-0.27, 3.97, 0.042), BinState::Measured);
  const MerlTable back = decode_merl(encode_merl(t), "t.binary");
  ASSERT_EQ(back.state(bin), BinState::Measured);
  EXPECT_EQ(back.value(bin)[0], 0.0);
  EXPECT_NEAR(back.value(bin)[1], 3.97, 1e-12);
  EXPECT_NEAR(back.value(bin)[2], 0.042, 1e-14);
  EXPECT_EQ(back.count_in_state(BinState::Measured), 1u);
  // Not a way to hide a broken value: NaN is still refused.
  t.set_value(bin, Rgb(std::nan(""), 1.0, 1.0), BinState::Measured);
  EXPECT_THROW(decode_merl(encode_merl(t), "t.binary"), DataError);
}

TEST(MerlFile, WrongSizeOrDimsIsADataError) {
  test::TempDir d;
  test::write_text(d / "short.binary", std::string(1000, '\0'));
  try {
    read_merl(d / "short.binary");
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("short.binary: expected 34992012 bytes, got 1000"));
  }
  std::string bytes = encode_merl(MerlTable());
  const std::int32_t dims[3] = {180, 90, 90};
  std::memcpy(bytes.data(), dims, 12);
  try {
    decode_merl(bytes, "swapped.binary");
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("swapped.binary: dimensions 180 x 90 x 90, expected 90 x 90 x 180"));
  }
  EXPECT_THROW(read_merl(d / "absent.binary"), IoError);
  // A failed read leaves nothing behind and a failed write of a folder path throws.
  EXPECT_THROW(write_merl(d / "no/such/dir/t.binary", MerlTable()), IoError);
}

TEST(MerlTable, StatisticsAndMeanCoordinates) {
  MerlTable t;
  const std::size_t bin = merl_flat_index({3, 4, 5});
  EXPECT_EQ(t.mean_coords(bin), merl_bin_centre(bin));  // no samples: the centre
  t.set_value(bin, Rgb(0.5, 0.6, 0.7), BinState::Filled);
  t.set_statistics(bin, 12, Rgb(0.01, 0.02, 0.03), Eigen::Vector3d(0.0021, 0.071, 0.0456));
  EXPECT_EQ(t.state(bin), BinState::Filled);
  EXPECT_EQ(t.count(bin), 12u);
  EXPECT_NEAR(t.variance(bin)[2], 0.03, 1e-8);
  EXPECT_NEAR(t.mean_coords(bin)[0], 0.0021, 1e-9);
  EXPECT_NEAR(t.mean_coords(bin)[2], 0.0456, 1e-8);
  EXPECT_EQ(t.count_in_state(BinState::Filled), 1u);
}

TEST(MerlTable, LookupIsExactAtCentresAndTrilinearBetween) {
  MerlTable t;
  // A field linear in the table's coordinates is reproduced exactly by trilinear lookup.
  auto field = [](double u, double v, double w) { return 0.3 + 0.01 * u + 0.02 * v + 0.005 * w; };
  for (std::size_t b = 0; b < kMerlBins; ++b) {
    const MerlBin mb = merl_bin_of_flat(b);
    t.set_value(b, Rgb::Constant(field(mb.theta_h + 0.5, mb.theta_d + 0.5, mb.phi_d + 0.5)), BinState::Measured);
  }
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(0, 1);
  for (int n = 0; n < 1000; ++n) {
    const double cu = 0.5 + 89 * u(rng), cv = 0.5 + 89 * u(rng), cw = 0.5 + 179 * u(rng);
    HalfDiff hd{(cu / 90) * (cu / 90) * std::numbers::pi / 2, 0.0, cv / 90 * std::numbers::pi / 2, cw / 180 * std::numbers::pi};
    auto v = t.lookup(hd);
    ASSERT_TRUE(v.has_value());
    ASSERT_NEAR((*v)[0], field(cu, cv, cw), 1e-9);
    // phi_d and phi_d - pi are the same point.
    hd.phi_d -= std::numbers::pi;
    ASSERT_NEAR((*t.lookup(hd))[1], field(cu, cv, cw), 1e-9);
  }
  // Across the phi_d seam the lookup blends bin 179 and bin 0.
  HalfDiff seam{merl_theta_h_centre(40), 0, merl_theta_d_centre(40), 0.0};
  const double a = t.value(merl_flat_index({40, 40, 179}))[0], b = t.value(merl_flat_index({40, 40, 0}))[0];
  EXPECT_NEAR((*t.lookup(seam))[0], 0.5 * (a + b), 1e-9);
}

TEST(MerlTable, LookupSkipsEmptyNeighbours) {
  MerlTable t;
  const std::size_t b = merl_flat_index({30, 30, 30});
  t.set_value(b, Rgb(0.2, 0.3, 0.4), BinState::Measured);
  HalfDiff between{merl_theta_h_centre(30), 0, 0.5 * (merl_theta_d_centre(30) + merl_theta_d_centre(31)),
                   merl_phi_d_centre(30)};
  auto v = t.lookup(between);
  ASSERT_TRUE(v.has_value());
  EXPECT_THAT(*v, test::RgbNear(Rgb(0.2, 0.3, 0.4), 1e-12));
  HalfDiff far{merl_theta_h_centre(60), 0, merl_theta_d_centre(60), merl_phi_d_centre(60)};
  EXPECT_FALSE(t.lookup(far).has_value());
  EXPECT_FALSE(t.lookup_nearest(far).has_value());
}
