// The 3MF module's entry (libisoslab_3mf.so, core/modules.h): the functions of lib3mf 1.8's C
// interface that encode/threemf_writer.cpp calls, in one table. The program and the library do not
// link lib3mf: it brings libzip, libcrypto and libbz2, whose binding cost about 6 ms at the start
// of every run (docs/design.md, "Loadable modules"). The writer loads the module on the first 3MF.
#pragma once

#include "Model/COM/NMR_DLLInterfaces.h"

namespace isoslab {

struct ThreeMfApi {
  decltype(&NMR::lib3mf_createmodel) createModel;
  decltype(&NMR::lib3mf_release) release;
  decltype(&NMR::lib3mf_getlasterror) getLastError;
  decltype(&NMR::lib3mf_model_setunit) setUnit;
  decltype(&NMR::lib3mf_model_setbuilduuidutf8) setBuildUuid;
  decltype(&NMR::lib3mf_model_addmeshobject) addMeshObject;
  decltype(&NMR::lib3mf_object_setuuidutf8) setObjectUuid;
  decltype(&NMR::lib3mf_object_setnameutf8) setObjectName;
  decltype(&NMR::lib3mf_meshobject_setgeometry) setGeometry;
  decltype(&NMR::lib3mf_model_addbasematerialgroup) addBaseMaterialGroup;
  decltype(&NMR::lib3mf_basematerial_getresourceid) getResourceId;
  decltype(&NMR::lib3mf_basematerial_addmaterialutf8) addMaterial;
  decltype(&NMR::lib3mf_object_createdefaultpropertyhandler) createDefaultPropertyHandler;
  decltype(&NMR::lib3mf_defaultpropertyhandler_setbasematerial) setBaseMaterial;
  decltype(&NMR::lib3mf_model_addbuilditem) addBuildItem;
  decltype(&NMR::lib3mf_builditem_setuuidutf8) setBuildItemUuid;
  decltype(&NMR::lib3mf_model_querywriter) queryWriter;
  decltype(&NMR::lib3mf_writer_writetocallback) writeToCallback;
};

/// The symbol that the module exports: a function without arguments returning the table.
inline constexpr const char* kThreeMfModuleEntry = "isoslab_3mf_module";

}  // namespace isoslab
