// The 3MF module's one exported symbol (encode/threemf_module.h).
#include "encode/threemf_module.h"

extern "C" __attribute__((visibility("default"))) const isoslab::ThreeMfApi* isoslab_3mf_module() {
  using namespace NMR;
  static const isoslab::ThreeMfApi api{
      .createModel = &lib3mf_createmodel,
      .release = &lib3mf_release,
      .getLastError = &lib3mf_getlasterror,
      .setUnit = &lib3mf_model_setunit,
      .setBuildUuid = &lib3mf_model_setbuilduuidutf8,
      .addMeshObject = &lib3mf_model_addmeshobject,
      .setObjectUuid = &lib3mf_object_setuuidutf8,
      .setObjectName = &lib3mf_object_setnameutf8,
      .setGeometry = &lib3mf_meshobject_setgeometry,
      .addBaseMaterialGroup = &lib3mf_model_addbasematerialgroup,
      .getResourceId = &lib3mf_basematerial_getresourceid,
      .addMaterial = &lib3mf_basematerial_addmaterialutf8,
      .createDefaultPropertyHandler = &lib3mf_object_createdefaultpropertyhandler,
      .setBaseMaterial = &lib3mf_defaultpropertyhandler_setbasematerial,
      .addBuildItem = &lib3mf_model_addbuilditem,
      .setBuildItemUuid = &lib3mf_builditem_setuuidutf8,
      .queryWriter = &lib3mf_model_querywriter,
      .writeToCallback = &lib3mf_writer_writetocallback,
  };
  return &api;
}
