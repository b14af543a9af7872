#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::slurp;

std::vector<std::map<std::string, std::string>> readCsv(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  std::vector<std::string> header;
  std::stringstream h(line);
  for (std::string c; std::getline(h, c, ',');) header.push_back(c);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(f, line)) {
    std::stringstream s(line);
    std::map<std::string, std::string> row;
    std::size_t i = 0;
    for (std::string c; std::getline(s, c, ',');) row[header.at(i++)] = c;
    rows.push_back(row);
  }
  return rows;
}

TEST(Compare, Spheres51SubsetHasTheExpectedRowsAndPrecision) {
  const std::string out = testing::tempDir();
  const auto r = testing::runCli("compare --suite spheres51 --radii 5,10,20 --no-charts -q --out " + out);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto rows = readCsv(out + "/results.csv");
  ASSERT_EQ(rows.size(), 3u * std::size(kMethods) * 2);
  std::map<std::pair<std::string, std::string>, double> triangles;  // (method, radius)
  for (const auto& row : rows) {
    for (const char* key : {"method", "field", "radius", "triangles", "area_error", "volume_error"}) {
      ASSERT_TRUE(row.contains(key)) << key;
    }
    if (row.at("field") == "distance") {
      triangles[{row.at("method"), row.at("radius")}] = std::stod(row.at("triangles"));
      if (row.at("radius") == "20") {
        EXPECT_LT(std::abs(std::stod(row.at("area_error"))), 0.005) << row.at("method");
        EXPECT_LT(std::abs(std::stod(row.at("volume_error"))), 0.005) << row.at("method");
      }
    }
    EXPECT_EQ(row.at("closed"), "1");
    EXPECT_EQ(row.at("euler"), "2");
  }
  for (const char* radius : {"5", "10", "20"}) {
    const double bcc = triangles[{"bcc12", radius}];
    const double mt6 = triangles[{"mt6", radius}];
    EXPECT_GT(bcc, mt6) << radius;
    const double mt24 = triangles[{"mt24", radius}];
    EXPECT_GT(mt24, bcc) << radius;
  }
  EXPECT_TRUE(fs::exists(out + "/summary.md"));
}

TEST(Compare, ChartsAreDrawnWithMatplotlib) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "Debian's python3-matplotlib is absent";
  }
  const std::string out = testing::tempDir();
  const auto r = testing::runCli("compare --suite spheres51 --radii 3,6 --methods mc,mt6 -q --out " + out);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const char* chart :
       {"chart1_triangles", "chart2_radius_error", "chart3_radius_error_per_triangle", "chart4_centroid_error",
        "chart5_centroid_error_per_triangle", "chart6_area_error", "chart7_volume_error"}) {
    const std::string png = out + "/" + chart + ".png";
    ASSERT_TRUE(fs::exists(png)) << png;
    EXPECT_EQ(slurp(png).substr(1, 3), "PNG");
  }
}

TEST(Compare, CubesSuiteReproducesTheBlockCount) {
  const std::string out = testing::tempDir();
  ASSERT_EQ(testing::runCli("compare --suite cubes -q --out " + out).exitCode, 0);
  const auto rows = readCsv(out + "/cubes.csv");
  ASSERT_EQ(rows.size(), 3u * 2 * std::size(kMethods));
  for (const auto& row : rows) {
    if (row.at("edge") == "6" && row.at("iso") == "50" && row.at("method") == "mc") {
      EXPECT_EQ(row.at("triangles"), "428");
    }
    if (row.at("edge") == "6" && row.at("iso") == "50" && row.at("method") == "mt6") {
      EXPECT_EQ(row.at("triangles"), "1584");
    }
    EXPECT_EQ(row.at("closed"), "1");
  }
}

TEST(Metrics, AWrittenPlyReproducesTheExtractReport) {
  const std::string dir = testing::tempDir();
  for (const char* method : {"mc", "bcc12"}) {
    const auto e = testing::runCli(std::string("extract 'phantom:sphere?n=48&r=15.3&c=23.2,24.1,22.7' -q --method ") +
                                   method + " -o " + dir + "/s.ply --report " + dir + "/e.json");
    ASSERT_EQ(e.exitCode, 0) << e.err;
    const auto extract = nlohmann::json::parse(slurp(dir + "/e.json"));
    const auto m = testing::runCli("metrics " + dir + "/s.ply --sphere 23.2,24.1,22.7,15.3");
    ASSERT_EQ(m.exitCode, 0) << m.err;
    const auto metrics = nlohmann::json::parse(m.out);
    const auto& a = extract["sphere"];
    const auto& b = metrics["sphere"];
    auto close = [](double x, double y) {
      return std::abs(x - y) <= 1e-9 * std::max(1e-300, std::max(std::abs(x), std::abs(y)));
    };
    for (const char* group : {"radius_error_vertex", "radius_error_centroid"}) {
      for (const char* key : {"sum", "sum_per_triangle", "mean", "mean_abs", "rms", "max_abs"}) {
        EXPECT_TRUE(close(a[group][key].get<double>(), b[group][key].get<double>()))
            << method << " " << group << " " << key;
      }
    }
    for (const char* key : {"area_error", "volume_error"})
      EXPECT_TRUE(close(a[key].get<double>(), b[key].get<double>())) << key;
    EXPECT_EQ(a["triangles"], b["triangles"]);
    EXPECT_LT(std::abs(a["area_error"].get<double>()), 0.01);
  }
}

}  // namespace
}  // namespace isoslab
