#include "mlmap/config/config_yaml.h"

#include "mlmap/config/yaml_section.h"

#include <yaml-cpp/yaml.h>

#include <stdexcept>

namespace mlmap::io {

void readEngineSections(Section& top, MapConfig* config) {
  MapConfig& c = *config;
  std::vector<std::string>& errors = *top.errors();
  {
    Section s(top.child("awareness"), "awareness", &errors);
    AwarenessConfig& a = c.awareness;
    s.read("rho_cell_m", &a.rho_cell_m);
    s.read("rho_cells", &a.rho_cells);
    s.read("phi_cells", &a.phi_cells);
    s.read("z_cell_m", &a.z_cell_m);
    s.read("z_cells", &a.z_cells);
    s.read("z_cells_below", &a.z_cells_below);
    s.read("min_range_m", &a.min_range_m);
    s.read("max_range_m", &a.max_range_m);
    s.read("sample_count", &a.sample_count);
    s.read("sample_seed", &a.sample_seed);
  }
  {
    Section s(top.child("log_odds"), "log_odds", &errors);
    LogOddsConfig& l = c.log_odds;
    s.read("hit", &l.hit);
    s.read("miss", &l.miss);
    s.read("clamp_min", &l.clamp_min);
    s.read("clamp_max", &l.clamp_max);
    s.read("occupied_threshold", &l.occupied_threshold);
  }
  {
    Section s(top.child("local_map"), "local_map", &errors);
    s.read("resolution_m", &c.local_map.resolution_m);
    s.readVector("size_cells", &c.local_map.size_cells);
  }
  {
    Section s(top.child("sensor"), "sensor", &errors);
    s.readVector("translation_B_m", &c.sensor.translation_B_m);
    s.readVector("rotation_rpy_deg", &c.sensor.rotation_rpy_deg);
  }
  {
    Section s(top.child("pipeline"), "pipeline", &errors);
    PipelineConfig& p = c.pipeline;
    s.read("threaded", &p.threaded);
    s.read("input_queue_capacity", &p.input_queue_capacity);
    s.read("batch_queue_capacity", &p.batch_queue_capacity);
    s.read("reject_out_of_order", &p.reject_out_of_order);
  }
  {
    Section s(top.child("projected_grid"), "projected_grid", &errors);
    ProjectedGridConfig& g = c.projected_grid;
    s.read("enabled", &g.enabled);
    s.read("relative_band", &g.relative_band);
    s.read("band_min_m", &g.band_min_m);
    s.read("band_max_m", &g.band_max_m);
    s.read("probability_values", &g.probability_values);
    s.read("include_global", &g.include_global);
  }
  {
    Section s(top.child("esdf"), "esdf", &errors);
    EsdfConfig& e = c.esdf;
    s.read("enabled", &e.enabled);
    s.read("max_distance_m", &e.max_distance_m);
    std::string unknown = toString(e.unknown_as);
    s.read("unknown_as", &unknown);
    if (unknown == "occupied") {
      e.unknown_as = UnknownAs::kOccupied;
    } else if (unknown == "free") {
      e.unknown_as = UnknownAs::kFree;
    } else {
      errors.push_back("esdf.unknown_as: must be occupied or free (got " + unknown + ")");
    }
    s.read("num_threads", &e.num_threads);
    s.read("max_rate_hz", &e.max_rate_hz);
    s.readVector("box_size_m", &e.box_size_m);
  }
}

MapConfig parseConfigYaml(const std::string& text, const std::string& source_name,
                          const std::vector<std::string>& skipped_sections) {
  const YAML::Node root = parseYamlDocument(text, source_name);
  MapConfig c;
  std::vector<std::string> errors;
  {
    Section top(root, "", &errors);
    readEngineSections(top, &c);
    for (const std::string& key : skipped_sections) (void)top.child(key);
  }  // reports unknown top-level keys
  stripTopLevelDots(&errors);
  if (errors.empty()) errors = c.validate();
  if (!errors.empty()) throwConfigErrors(source_name, errors);
  return c;
}

MapConfig loadConfigYaml(const std::string& path, const std::vector<std::string>& skipped_sections) {
  return parseConfigYaml(readConfigFile(path), path, skipped_sections);
}

std::string toYaml(const MapConfig& c) {
  YAML::Emitter out;
  out.SetDoublePrecision(15);  // 0.1 prints as 0.1; anything typed with <= 15 digits round-trips
  auto vec = [&](const auto& v) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int i = 0; i < v.size(); ++i) out << v[i];
    out << YAML::EndSeq;
  };
  out << YAML::BeginMap;
  out << YAML::Key << "awareness" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rho_cell_m" << YAML::Value << c.awareness.rho_cell_m;
  out << YAML::Key << "rho_cells" << YAML::Value << c.awareness.rho_cells;
  out << YAML::Key << "phi_cells" << YAML::Value << c.awareness.phi_cells;
  out << YAML::Key << "z_cell_m" << YAML::Value << c.awareness.z_cell_m;
  out << YAML::Key << "z_cells" << YAML::Value << c.awareness.z_cells;
  out << YAML::Key << "z_cells_below" << YAML::Value << c.awareness.z_cells_below;
  out << YAML::Key << "min_range_m" << YAML::Value << c.awareness.min_range_m;
  out << YAML::Key << "max_range_m" << YAML::Value << c.awareness.max_range_m;
  out << YAML::Key << "sample_count" << YAML::Value << c.awareness.sample_count;
  out << YAML::Key << "sample_seed" << YAML::Value << c.awareness.sample_seed;
  out << YAML::EndMap;
  out << YAML::Key << "log_odds" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "hit" << YAML::Value << c.log_odds.hit;
  out << YAML::Key << "miss" << YAML::Value << c.log_odds.miss;
  out << YAML::Key << "clamp_min" << YAML::Value << c.log_odds.clamp_min;
  out << YAML::Key << "clamp_max" << YAML::Value << c.log_odds.clamp_max;
  out << YAML::Key << "occupied_threshold" << YAML::Value << c.log_odds.occupied_threshold;
  out << YAML::EndMap;
  out << YAML::Key << "local_map" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "resolution_m" << YAML::Value << c.local_map.resolution_m;
  out << YAML::Key << "size_cells" << YAML::Value;
  vec(c.local_map.size_cells);
  out << YAML::EndMap;
  out << YAML::Key << "sensor" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "translation_B_m" << YAML::Value;
  vec(c.sensor.translation_B_m);
  out << YAML::Key << "rotation_rpy_deg" << YAML::Value;
  vec(c.sensor.rotation_rpy_deg);
  out << YAML::EndMap;
  out << YAML::Key << "pipeline" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "threaded" << YAML::Value << c.pipeline.threaded;
  out << YAML::Key << "input_queue_capacity" << YAML::Value << c.pipeline.input_queue_capacity;
  out << YAML::Key << "batch_queue_capacity" << YAML::Value << c.pipeline.batch_queue_capacity;
  out << YAML::Key << "reject_out_of_order" << YAML::Value << c.pipeline.reject_out_of_order;
  out << YAML::EndMap;
  out << YAML::Key << "projected_grid" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enabled" << YAML::Value << c.projected_grid.enabled;
  out << YAML::Key << "relative_band" << YAML::Value << c.projected_grid.relative_band;
  out << YAML::Key << "band_min_m" << YAML::Value << c.projected_grid.band_min_m;
  out << YAML::Key << "band_max_m" << YAML::Value << c.projected_grid.band_max_m;
  out << YAML::Key << "probability_values" << YAML::Value << c.projected_grid.probability_values;
  out << YAML::Key << "include_global" << YAML::Value << c.projected_grid.include_global;
  out << YAML::EndMap;
  out << YAML::Key << "esdf" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "enabled" << YAML::Value << c.esdf.enabled;
  out << YAML::Key << "max_distance_m" << YAML::Value << c.esdf.max_distance_m;
  out << YAML::Key << "unknown_as" << YAML::Value << toString(c.esdf.unknown_as);
  out << YAML::Key << "num_threads" << YAML::Value << c.esdf.num_threads;
  out << YAML::Key << "max_rate_hz" << YAML::Value << c.esdf.max_rate_hz;
  out << YAML::Key << "box_size_m" << YAML::Value;
  vec(c.esdf.box_size_m);
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace mlmap::io
