#include "gpisvdb/app/band_metadata.h"

namespace gpisvdb::app {

openvdb::MetaMap bandMetadata(const BandProvenance& provenance, const ModelOptions& modelOptions, const LoadedModel& model,
                              const BandOptions& options, const Resolution& resolution, bool budgeted, const BandResult& result,
                              const VdbWriteOptions& vdb) {
    openvdb::MetaMap meta;
    const InputSamples& in = model.input;
    // === Provenance and the model
    meta.insertMeta("gpisvdb_version", openvdb::StringMetadata(GPISVDB_VERSION));
    meta.insertMeta("command_line", openvdb::StringMetadata(provenance.commandLine));
    meta.insertMeta("input", openvdb::StringMetadata(provenance.input));
    meta.insertMeta("input_samples", openvdb::Int64Metadata(openvdb::Int64(in.samples.size())));
    meta.insertMeta("normals_flipped", openvdb::BoolMetadata(in.normalsFlipped));
    meta.insertMeta("length_scale", openvdb::DoubleMetadata(in.samples.lengthScale));
    meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(modelOptions.sigmaRel));
    meta.insertMeta("sigma", openvdb::DoubleMetadata(in.sigma));
    meta.insertMeta("smoothing_rel", openvdb::DoubleMetadata(modelOptions.smoothingRel));
    meta.insertMeta("smoothing", openvdb::DoubleMetadata(model.smoothing));
    meta.insertMeta("smoothing_set_by", openvdb::StringMetadata(smoothingSourceName(model.smoothingSource)));
    meta.insertMeta("merge_rel", openvdb::DoubleMetadata(modelOptions.mergeRel));
    meta.insertMeta("model_samples", openvdb::Int64Metadata(openvdb::Int64(model.modelSamples)));
    meta.insertMeta("model", openvdb::StringMetadata(modelOptions.kind == ModelKind::Regression ? "regression" : "winding"));
    if (model.trainingSize) {
        meta.insertMeta("training_labels", openvdb::Int64Metadata(openvdb::Int64(model.trainingSize)));
        meta.insertMeta("label_noise", openvdb::DoubleMetadata(modelOptions.labelNoise));
        if (!provenance.labelsPath.empty()) meta.insertMeta("labels", openvdb::StringMetadata(provenance.labelsPath));
    }
    // === The band as built
    meta.insertMeta("iso", openvdb::DoubleMetadata(options.iso));
    meta.insertMeta("eta_rel", openvdb::DoubleMetadata(options.etaRelative));
    meta.insertMeta("eta", openvdb::DoubleMetadata(result.stats.etaAbsolute));
    meta.insertMeta("voxel_size", openvdb::DoubleMetadata(options.voxelSize));
    meta.insertMeta("h_star", openvdb::DoubleMetadata(resolution.hStar));
    meta.insertMeta("mu_width", openvdb::DoubleMetadata(resolution.muWidth));
    meta.insertMeta("voxel_values", openvdb::StringMetadata(voxelValuesName(options.values)));
    meta.insertMeta("voxel_size_set_by_budget", openvdb::BoolMetadata(budgeted));
    meta.insertMeta("qmc_samples", openvdb::Int32Metadata(options.qmcSamples));
    meta.insertMeta("beta", openvdb::DoubleMetadata(modelOptions.barnesHut.beta));
    meta.insertMeta("exact", openvdb::BoolMetadata(modelOptions.exact));
    meta.insertMeta("max_anisotropy", openvdb::DoubleMetadata(options.maxAnisotropy));
    meta.insertMeta("band_voxels", openvdb::Int64Metadata(openvdb::Int64(result.band.size())));
    meta.insertMeta("band_mass", openvdb::DoubleMetadata(result.band.mass()));
    meta.insertMeta("half_float", openvdb::BoolMetadata(vdb.halfFloat));
    meta.insertMeta("occupancy_grid", openvdb::StringMetadata(vdb.occupancyName));
    return meta;
}

}  // namespace gpisvdb::app
