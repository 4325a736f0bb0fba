// The PicoScan filter plugin for MeshLab 2020.09: structured-light scanning filters that
// wrap the PicoScan core. The plugin only translates parameters, layers and messages; the
// work is done by picoscan_core.
#pragma once

#include <common/interfaces.h>

#include <vector>

class PicoScanFilterPlugin : public QObject, public MeshFilterInterface {
    Q_OBJECT
    MESHLAB_PLUGIN_IID_EXPORTER(MESH_FILTER_INTERFACE_IID)
    Q_INTERFACES(MeshFilterInterface)

public:
    enum FilterId { Reconstruct, Simulate, Clean, Align, Fuse, Measure, SaveViews, Section };

    PicoScanFilterPlugin();

    QString pluginName() const override;
    QString filterName(FilterIDType filter) const override;
    QString filterInfo(FilterIDType filter) const override;
    FilterClass getClass(QAction* action) override;
    FILTER_ARITY filterArity(QAction* action) const override;
    int getPreConditions(QAction* action) const override;
    int postCondition(QAction* action) const override;
    int getRequirements(QAction* action) override;
    // MeshLab asks for parameters with the document (md.mm() is null when a script starts
    // without an input mesh); the per-mesh overload is not used.
    using MeshFilterInterface::initParameterSet;
    void initParameterSet(QAction* action, MeshDocument& document, RichParameterList& parameters) override;
    bool applyFilter(QAction* action, MeshDocument& document, const RichParameterList& parameters,
                     vcg::CallBackPos* callback) override;

private:
    void reconstruct(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback);
    void simulate(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback);
    void clean(MeshDocument& document, const RichParameterList& parameters);
    void align(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback);
    void fuse(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback);
    void measure(MeshDocument& document, const RichParameterList& parameters);
    void save_views(MeshDocument& document, const RichParameterList& parameters);
    void section(MeshDocument& document, const RichParameterList& parameters, vcg::CallBackPos* callback);
    // Clean, Align and Fuse need the pixel grid and camera: refused with the reason, or logged
    // when they were taken from a view file.
    void require_scan_grid(MeshModel& layer);
    std::vector<MeshModel*> visible_scan_layers(MeshDocument& document);
};
