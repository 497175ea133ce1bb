"""SSP test helpers: archives laid out the way OMSimulator and easySSP write them."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

SSP_NAMESPACES = (
    'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
    'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
    'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
    'xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping" '
    'xmlns:ssb="http://ssp-standard.org/SSP1/SystemStructureSignalDictionary" '
    'xmlns:oms="https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"'
)

#: A system as OMSimulator 2.x writes it: version 2.0 with SSP1 namespaces, a root system,
#: a nested system with its own connectors, a `.ssv` bound with a prefix, an `.ssm` mapping,
#: a linear transformation, a unit conversion, and the step in an `org.openmodelica`
#: annotation. integ.x = t (u=1); gain1.y = 3 x; ctrl.gain2.u = 2 gain1.y + 1 (via `ctrl.in`);
#: ctrl.gain2.k = 0.5 * 8 = 4 (mapped from `gainValue`); tail.u = 1000 * gain2.y (km -> m).
FOREIGN_SSD = f"""<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription {SSP_NAMESPACES} name="model" version="2.0">
  <ssd:System name="root">
    <ssd:ParameterBindings>
      <ssd:ParameterBinding source="resources/gain1.ssv" prefix="gain1.">
      </ssd:ParameterBinding>
    </ssd:ParameterBindings>
    <ssd:Elements>
      <ssd:Component name="integ" type="application/x-fmu-sharedlibrary"
          source="resources/0001_integ.fmu">
        <ssd:Connectors>
          <ssd:Connector name="x" kind="output"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding>
            <ssd:ParameterValues>
              <ssv:ParameterSet version="2.0" name="parameters">
                <ssv:Parameters>
                  <ssv:Parameter name="u"><ssv:Real value="1"/></ssv:Parameter>
                </ssv:Parameters>
              </ssv:ParameterSet>
            </ssd:ParameterValues>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>
      </ssd:Component>
      <ssd:Component name="gain1" type="application/x-fmu-sharedlibrary"
          source="resources/0002_gain1.fmu">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="y" kind="output"><ssc:Real/>
            <ssd:ConnectorGeometry x="1.0" y="0.5"/></ssd:Connector>
          <ssd:Connector name="k" kind="parameter"><ssc:Real/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
      <ssd:System name="ctrl">
        <ssd:Connectors>
          <ssd:Connector name="in" kind="input"><ssc:Real/></ssd:Connector>
          <ssd:Connector name="out" kind="output"><ssc:Real unit="km"/></ssd:Connector>
        </ssd:Connectors>
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="resources/ctrl.ssv">
            <ssd:ParameterMapping source="resources/ctrl.ssm"/>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>
        <ssd:Elements>
          <ssd:Component name="gain2" type="application/x-fmu-sharedlibrary"
              source="resources/0003_gain2.fmu">
            <ssd:Connectors>
              <ssd:Connector name="u" kind="input"><ssc:Real/></ssd:Connector>
              <ssd:Connector name="y" kind="output"><ssc:Real unit="km"/></ssd:Connector>
            </ssd:Connectors>
          </ssd:Component>
        </ssd:Elements>
        <ssd:Connections>
          <ssd:Connection startConnector="in" endElement="gain2" endConnector="u"/>
          <ssd:Connection startElement="gain2" startConnector="y" endConnector="out"/>
        </ssd:Connections>
      </ssd:System>
      <ssd:Component name="tail" type="application/x-fmu-sharedlibrary"
          source="resources/0002_gain1.fmu">
        <ssd:Connectors>
          <ssd:Connector name="u" kind="input"><ssc:Real unit="m"/></ssd:Connector>
        </ssd:Connectors>
      </ssd:Component>
    </ssd:Elements>
    <ssd:Connections>
      <ssd:Connection startElement="integ" startConnector="x" endElement="gain1" endConnector="u"/>
      <ssd:Connection startElement="gain1" startConnector="y" endElement="ctrl" endConnector="in">
        <ssc:LinearTransformation factor="2" offset="1"/>
      </ssd:Connection>
      <ssd:Connection startElement="ctrl" startConnector="out" endElement="tail" endConnector="u"/>
    </ssd:Connections>
    <ssd:Annotations>
      <ssc:Annotation type="org.openmodelica">
        <oms:Annotations>
          <oms:SimulationInformation>
            <oms:FixedStepMaster description="oms-ma" stepSize="0.010000"
                relativeTolerance="0.000100"/>
          </oms:SimulationInformation>
        </oms:Annotations>
      </ssc:Annotation>
    </ssd:Annotations>
  </ssd:System>
  <ssd:Units>
    <ssc:Unit name="km"><ssc:BaseUnit m="1" factor="1000"/></ssc:Unit>
    <ssc:Unit name="m"><ssc:BaseUnit m="1"/></ssc:Unit>
  </ssd:Units>
  <ssd:DefaultExperiment startTime="0.000000" stopTime="1.000000"/>
</ssd:SystemStructureDescription>
"""

GAIN1_SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    version="2.0" name="gain1">
  <ssv:Parameters>
    <ssv:Parameter name="k"><ssv:Real value="3"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"""

CTRL_SSV = """<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    version="2.0" name="ctrl">
  <ssv:Parameters>
    <ssv:Parameter name="gainValue"><ssv:Real value="8"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"""

CTRL_SSM = """<?xml version="1.0" encoding="UTF-8"?>
<ssm:ParameterMapping xmlns:ssm="http://ssp-standard.org/SSP1/SystemStructureParameterMapping"
    xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="2.0">
  <ssm:MappingEntry source="gainValue" target="gain2.k">
    <ssc:LinearTransformation factor="0.5"/>
  </ssm:MappingEntry>
</ssm:ParameterMapping>
"""


def write_ssp(path: Path, members: dict[str, bytes | str | Path]) -> Path:
    """Zip ``members`` (archive name -> bytes, text, or a file to copy) into ``path``."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            if isinstance(content, Path):
                archive.write(content, name)
            else:
                archive.writestr(name, content)
    return path


@pytest.fixture(autouse=True)
def _private_cache(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each test session unpacks archives into its own cache, never the user's."""
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


@pytest.fixture
def foreign_ssp(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    """The OMSimulator-style archive of :data:`FOREIGN_SSD` with real test FMUs."""
    gain = fixture_fmu("Gain")
    return write_ssp(
        tmp_path / "foreign.ssp",
        {
            "SystemStructure.ssd": FOREIGN_SSD,
            "resources/0001_integ.fmu": fixture_fmu("Integrator"),
            "resources/0002_gain1.fmu": gain,
            "resources/0003_gain2.fmu": gain,
            "resources/gain1.ssv": GAIN1_SSV,
            "resources/ctrl.ssv": CTRL_SSV,
            "resources/ctrl.ssm": CTRL_SSM,
        },
    )
