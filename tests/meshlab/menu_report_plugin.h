// Test-only MeshLab plugin (built with the tests, copied only into the test prefix): with
// PICOSCAN_MESHLAB_MENU_REPORT=FILE it writes MeshLab's Filters menu to FILE once the main
// window is up, so the GUI test reads the real menu. With PICOSCAN_MESHLAB_EXPORT_AS=PLY it saves
// the current layer through File > Export Mesh As and MeshLab's own PLY options dialog, writing
// the dialog's boxes to PICOSCAN_MESHLAB_EXPORT_REPORT and unticking those named (comma-separated)
// in PICOSCAN_MESHLAB_EXPORT_UNTICK. It adds no filter of its own.
#pragma once

#include <common/interfaces.h>

class MenuReportPlugin : public QObject, public MeshFilterInterface {
    Q_OBJECT
    MESHLAB_PLUGIN_IID_EXPORTER(MESH_FILTER_INTERFACE_IID)
    Q_INTERFACES(MeshFilterInterface)

public:
    MenuReportPlugin();
    QString pluginName() const override;
    QString filterName(FilterIDType) const override { return {}; }
    QString filterInfo(FilterIDType) const override { return {}; }
    FILTER_ARITY filterArity(QAction*) const override { return NONE; }
    bool applyFilter(QAction*, MeshDocument&, const RichParameterList&, vcg::CallBackPos*) override { return false; }
};
