<?xml version="1.0" encoding="UTF-8"?>
<!-- made for inkmotion's tests: screen 200 x 100, one pen-up move, two strokes with times -->
<gml spec="1.0">
  <tag>
    <header>
      <environment>
        <up><x>0</x><y>-1</y><z>0</z></up>
        <screenBounds><x>200</x><y>100</y><z>0</z></screenBounds>
      </environment>
    </header>
    <drawing>
      <stroke isdrawing="false">
        <pt><x>0.9</x><y>0.9</y><t>0.0</t></pt>
        <pt><x>0.1</x><y>0.1</y><t>0.1</t></pt>
      </stroke>
      <stroke>
        <pt><x>0.0</x><y>0.0</y><z>0.0</z><t>0.2</t></pt>
        <pt><x>1.0</x><y>0.0</y><z>0.0</z><t>0.3</t></pt>
        <pt><x>1.0</x><y>1.0</y><z>0.0</z><t>0.4</t></pt>
      </stroke>
      <stroke>
        <pt><x>0.5</x><y>0.5</y><time>0.5</time></pt>
        <pt><x>0.5</x><y>0.75</y><time>0.6</time></pt>
      </stroke>
    </drawing>
  </tag>
</gml>
