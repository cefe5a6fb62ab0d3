<gml spec="1.0">
  <tag>
    <header>
      <environment>
        <up><x>1</x><y>0</y><z>0</z></up>
        <screenBounds><x>200</x><y>100</y></screenBounds>
      </environment>
    </header>
    <drawing>
      <stroke>
        <pt><x>0.0</x><y>0.0</y></pt>
        <pt><x>1.0</x><y>0.0</y></pt>
        <pt><x>1.0</x><y>1.0</y></pt>
      </stroke>
    </drawing>
  </tag>
</gml>
