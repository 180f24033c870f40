#include "octo_slice_mapper/option_table.h"

#include <cstdio>
#include <cstdlib>

namespace octo_slice_mapper {

const std::vector<OptionSpec<MapperOptions>>& mapperOptionTable() {
  using O = MapperOptions;
  static const std::vector<OptionSpec<MapperOptions>> table = {
      {"resolution", "m", "octree leaf size", [](O& o) -> OptionField { return &o.resolution; }},
      {"clamp_min", "", "OctoMap's lower clamping bound (probability)", [](O& o) -> OptionField { return &o.clamp_min; }},
      {"clamp_max", "", "OctoMap's upper clamping bound (probability)", [](O& o) -> OptionField { return &o.clamp_max; }},
      {"max_range", "m", "returns beyond are cut: cleared up to it, nothing marked (0 = the sensor's range_max)",
       [](O& o) -> OptionField { return &o.insert.max_range; }},
      {"inf_is_no_return", "", "REP 117: +inf is a no-return, -inf too close, NaN invalid",
       [](O& o) -> OptionField { return &o.insert.readings.inf_is_no_return; }},
      {"evidence_combining", "", "how a scan's beams combine per voxel: sum or occupied_wins",
       [](O& o) -> OptionField { return &o.insert.combining; }},
      {"beam_opening_angle", "rad", "full cone angle of one beam",
       [](O& o) -> OptionField { return &o.insert.model.beam_opening_angle; }, true},
      {"cone_covers_angle_step", "", "widen every cone to the scan's angle step",
       [](O& o) -> OptionField { return &o.insert.model.cone_covers_angle_step; }},
      {"cone_taper_fraction", "", "outer share of the half-angle over which evidence fades",
       [](O& o) -> OptionField { return &o.insert.model.cone_taper_fraction; }, true},
      {"sigma_base", "m", "range std. dev. at 0 m", [](O& o) -> OptionField { return &o.insert.model.sigma_base; }, true},
      {"sigma_per_meter", "", "range std. dev. growth per metre",
       [](O& o) -> OptionField { return &o.insert.model.sigma_per_meter; }, true},
      {"sigma_angle_gain", "", "sigma grows by up to this factor towards the cone's edge",
       [](O& o) -> OptionField { return &o.insert.model.sigma_angle_gain; }, true},
      {"p_free", "", "probability in the free valley", [](O& o) -> OptionField { return &o.insert.model.p_free; }, true},
      {"p_occupied", "", "probability of a voxel holding the whole occupied peak",
       [](O& o) -> OptionField { return &o.insert.model.p_occupied; }, true},
      {"prior", "", "prior occupancy, subtracted from every update", [](O& o) -> OptionField { return &o.insert.model.prior; }},
      {"no_return_clear_distance", "m", "no-returns clear space up to here (0 = ignore them)",
       [](O& o) -> OptionField { return &o.insert.model.no_return_clear_distance; }, true},
      {"cloud_one_ray_per_voxel", "", "point clouds: one ray per voxel that returns end in (false: one per point)",
       [](O& o) -> OptionField { return &o.insert.cloud_one_ray_per_voxel; }},
      {"cloud_max_range", "m", "point clouds: returns beyond are cut: cleared up to it, nothing marked (0 = max_range)",
       [](O& o) -> OptionField { return &o.insert.cloud_max_range; }},
      {"cloud_evidence_combining", "", "point clouds: how a frame's rays combine per voxel: occupied_wins or sum",
       [](O& o) -> OptionField { return &o.insert.cloud_combining; }},
      {"cloud_shared_free_run", "",
       "point clouds: a ray stops after this many voxels in a row that earlier rays of the frame cleared "
       "(occupied_wins only; 0 = every ray walked whole)",
       [](O& o) -> OptionField { return &o.insert.cloud_shared_free_run; }},
      {"cloud_mark_min_z", "m",
       "point clouds: only returns at least this high above the floor under them mark (the floor clears only)",
       [](O& o) -> OptionField { return &o.insert.cloud_mark_min_z; }},
      {"cloud_mark_max_z", "m", "point clouds: only returns at most this high above the floor mark",
       [](O& o) -> OptionField { return &o.insert.cloud_mark_max_z; }},
      {"cloud_noise_base", "m", "point clouds: depth noise sigma at near range (Kinect v1: 0.0012)",
       [](O& o) -> OptionField { return &o.insert.cloud_noise_base; }},
      {"cloud_noise_quadratic", "1/m", "point clouds: sigma grows by this times (range - cloud_noise_near)^2 (Kinect v1: 0.0019)",
       [](O& o) -> OptionField { return &o.insert.cloud_noise_quadratic; }},
      {"cloud_noise_near", "m", "point clouds: range where the noise starts to grow (Kinect v1: 0.4)",
       [](O& o) -> OptionField { return &o.insert.cloud_noise_near; }},
      {"cloud_mark_sigmas", "", "point clouds: a return marks only this many noise sigmas above the floor (0 = off)",
       [](O& o) -> OptionField { return &o.insert.cloud_mark_sigmas; }},
      {"cloud_flying_pixel_filter", "", "point clouds: leave out an organized frame's flying pixels (mixed pixels at depth edges)",
       [](O& o) -> OptionField { return &o.insert.cloud_flying_pixels.enabled; }},
      {"cloud_flying_pixel_gap", "m", "point clouds: a neighbour pixel is close within this plus cloud_flying_pixel_gap_per_metre x range "
       "(a pixel close to fewer than two of its eight, or beyond it between two opposite ones and off the line through them, "
       "is flying)",
       [](O& o) -> OptionField { return &o.insert.cloud_flying_pixels.gap_base; }},
      {"cloud_flying_pixel_gap_per_metre", "", "point clouds: the close gap's growth with range",
       [](O& o) -> OptionField { return &o.insert.cloud_flying_pixels.gap_per_metre; }},
      {"floor_find", "", "find the floor in depth frames (false: the fixed frame's z = 0 is the floor)",
       [](O& o) -> OptionField { return &o.floor.find; }},
      {"floor_max_tilt", "rad", "a floor plane's normal lies within this of vertical",
       [](O& o) -> OptionField { return &o.floor.fit.max_tilt; }},
      {"floor_inlier_distance", "m", "a return this close to the plane is floor",
       [](O& o) -> OptionField { return &o.floor.fit.inlier_distance; }},
      {"floor_min_points", "", "a floor needs this many of a frame's end voxels (about 0.3 m^2 at 0.05 m)",
       [](O& o) -> OptionField { return &o.floor.fit.min_points; }},
      {"floor_min_below_sensor", "m", "the floor lies at least this far below the sensor",
       [](O& o) -> OptionField { return &o.floor.fit.min_below_sensor; }},
      {"floor_max_rise", "m",
       "once a floor is known, a level surface more than this above it is not the floor (where the floor under "
       "the sensor was seen: more than cloud_mark_min_z)",
       [](O& o) -> OptionField { return &o.floor.max_rise; }},
      {"slice_min_z", "m", "lower end of the height band (above the floor) projected into the slice",
       [](O& o) -> OptionField { return &o.slice.min_z; }, true},
      {"slice_max_z", "m", "upper end of the height band (above the floor)", [](O& o) -> OptionField { return &o.slice.max_z; }, true},
      {"keep_scans", "", "keep scans for the global pass", [](O& o) -> OptionField { return &o.keep_scans; }},
      {"keyframe_min_distance", "m", "keep a scan only after the laser moved this much",
       [](O& o) -> OptionField { return &o.scan_store.min_distance; }},
      {"keyframe_min_rotation", "rad", "... or turned this much", [](O& o) -> OptionField { return &o.scan_store.min_rotation; }},
      {"max_kept_scans", "", "bound of the scan store", [](O& o) -> OptionField { return &o.scan_store.max_scans; }},
      {"revisit_cell", "m", "a scan taken within this of a kept one (and revisit_angle) is not kept",
       [](O& o) -> OptionField { return &o.scan_store.revisit_cell; }},
      {"revisit_angle", "rad", "heading sector of a revisit", [](O& o) -> OptionField { return &o.scan_store.revisit_angle; }},
      {"forward_z_hit", "", "forward model: weight of the Gaussian around the expected range",
       [](O& o) -> OptionField { return &o.optimizer.model.z_hit; }, true},
      {"forward_z_rand", "", "forward model: weight of random readings", [](O& o) -> OptionField { return &o.optimizer.model.z_rand; }, true},
      {"forward_z_miss", "", "forward model: weight of max-range readings", [](O& o) -> OptionField { return &o.optimizer.model.z_miss; }, true},
      {"forward_sigma_base", "m", "forward model: range noise at 0 m",
       [](O& o) -> OptionField { return &o.optimizer.model.sigma_base; }, true},
      {"forward_sigma_per_meter", "", "forward model: range noise growth per metre",
       [](O& o) -> OptionField { return &o.optimizer.model.sigma_per_meter; }, true},
      {"forward_trace_sigmas", "", "forward model: a cell this many sigmas beyond a return cannot explain it",
       [](O& o) -> OptionField { return &o.optimizer.model.trace_sigmas; }},
      {"forward_beam_opening_angle", "rad", "global pass: beam cone (0 = a thin beam along its axis)",
       [](O& o) -> OptionField { return &o.optimizer.beam_opening_angle; }},
      {"forward_max_range", "m", "global pass: returns beyond are not used (0 = the sensor's range_max)",
       [](O& o) -> OptionField { return &o.optimizer.max_range; }},
      {"max_sweeps", "", "global pass: at most this many sweeps", [](O& o) -> OptionField { return &o.optimizer.max_sweeps; }},
      {"optimizer_threads", "", "global pass: worker threads (0 = every core; the map is the same for any number)",
       [](O& o) -> OptionField { return &o.optimizer.threads; }},
  };
  return table;
}

bool evidenceCombiningFromName(const std::string& name, EvidenceCombining* out) {
  if (name == "sum") *out = EvidenceCombining::kSum;
  else if (name == "occupied_wins") *out = EvidenceCombining::kOccupiedWins;
  else return false;
  return true;
}

const char* evidenceCombiningName(EvidenceCombining combining) {
  return combining == EvidenceCombining::kSum ? "sum" : "occupied_wins";
}

std::string optionValueText(const OptionField& field) {
  struct Text {
    std::string operator()(const double* v) const {
      char s[32];
      std::snprintf(s, sizeof s, "%g", *v);
      return s;
    }
    std::string operator()(const bool* v) const { return *v ? "true" : "false"; }
    std::string operator()(const int* v) const { return std::to_string(*v); }
    std::string operator()(const std::size_t* v) const { return std::to_string(*v); }
    std::string operator()(const std::string* v) const { return *v; }
    std::string operator()(const EvidenceCombining* v) const { return evidenceCombiningName(*v); }
  };
  return std::visit(Text(), field);
}

bool setOptionFromText(const OptionField& field, const std::string& text) {
  struct Set {
    const std::string& text;
    bool operator()(double* v) const {
      char* end = nullptr;
      const double d = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0') return false;
      *v = d;
      return true;
    }
    bool operator()(bool* v) const {
      if (text != "true" && text != "false") return false;
      *v = text == "true";
      return true;
    }
    bool operator()(int* v) const {
      char* end = nullptr;
      const long n = std::strtol(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0') return false;
      *v = static_cast<int>(n);
      return true;
    }
    bool operator()(std::size_t* v) const {
      char* end = nullptr;
      const unsigned long long n = std::strtoull(text.c_str(), &end, 10);
      if (text.empty() || text[0] == '-' || *end != '\0') return false;
      *v = static_cast<std::size_t>(n);
      return true;
    }
    bool operator()(std::string* v) const {
      *v = text;
      return true;
    }
    bool operator()(EvidenceCombining* v) const { return evidenceCombiningFromName(text, v); }
  };
  return std::visit(Set{text}, field);
}

std::string optionFlag(const char* name) {
  std::string flag = std::string("--") + name;
  for (char& c : flag) c = c == '_' ? '-' : c;
  return flag;
}

}  // namespace octo_slice_mapper
